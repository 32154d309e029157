// Point-to-element form factors: the integrand of the radiosity equation without visibility.
//
// A receiving point has two sides (Cycles' surfaces are two-sided), so every factor comes as the
// part seen by the hemisphere around +n (front) and the part seen around -n (back).
#pragma once

#include <glm/glm.hpp>

namespace radiosity {

using glm::dvec3;

// Lambert's formula for the form factor from a differential area at x, normal n, to a polygon,
// counting only the part of the polygon in the hemisphere n points to (the polygon is clipped to
// that half-space first: the unclipped formula is wrong near the horizon).
double polygon_form_factor(const dvec3& x, const dvec3& n, const dvec3* polygon, int count);

struct SideFactors {
  double front = 0.0;
  double back = 0.0;
};

// A planar-enough quadrilateral piece of a shooter with its sample point at the centre.
struct Cell {
  dvec3 corners[4];
  dvec3 centre;
  dvec3 normal;  // unit, front side of the shooter
  double area;
  double radius; // largest centre-to-corner distance
};

// Form factor from (x, n) to the cell, by Lambert's formula: a point sample would blow up as 1/r^2
// near the cell, and costs little less than the exact value next to a visibility ray.
SideFactors cell_form_factor(const Cell& cell, const dvec3& x, const dvec3& n);

// Splits the bilinear patch p0 p1 p2 p3 (counter-clockwise) into k x k cells at their centres:
// the paper's m x n micro-elements, evaluated by the midpoint rule.
void bilinear_cells(const dvec3 p[4], int k, Cell* out);

// Bilinear interpolation of four corner values at (u, v), corners ordered as the patch.
template <class T>
T bilinear(const T c[4], double u, double v) {
  return (1 - u) * (1 - v) * c[0] + u * (1 - v) * c[1] + u * v * c[2] + (1 - u) * v * c[3];
}

}  // namespace radiosity
