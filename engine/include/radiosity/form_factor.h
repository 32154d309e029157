// Point-to-element form factors: the integrand of the radiosity equation without visibility.
//
// A receiving point has two sides (Cycles' surfaces are two-sided), so every factor comes as the
// part seen by the hemisphere around +n (front) and the part seen around -n (back).
#pragma once

#include <glm/glm.hpp>

#include <optional>

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

// A symmetric 3 x 3 matrix: six numbers where a dmat3 holds nine.
struct Symmetric3 {
  double xx = 0, yy = 0, zz = 0, xy = 0, xz = 0, yz = 0;
  dvec3 operator*(const dvec3& v) const {
    return dvec3(xx * v.x + xy * v.y + xz * v.z, xy * v.x + yy * v.y + yz * v.z, xz * v.x + yz * v.y + zz * v.z);
  }
  double trace() const { return xx + yy + zz; }
};

// A planar-enough quadrilateral piece of a shooter with its sample point at the centre.
// What a distant receiver reads comes first, the corners last: most cells a receiver visits are far.
struct Cell {
  dvec3 centroid;     // of its area
  dvec3 normal;       // unit, front side of the shooter
  double area;
  double radius;      // largest centre-to-corner distance
  double reach;       // largest centroid-to-corner distance
  Symmetric3 spread;  // second moment of its area about the centroid, per unit area
  dvec3 centre;       // of its square in the patch's (u, v): where rays aim
  dvec3 corners[4];
};

// Form factor from (x, n) to the cell, by Lambert's formula: a point sample would blow up as 1/r^2
// near the cell, and costs little less than the exact value next to a visibility ray.
SideFactors cell_form_factor(const Cell& cell, const dvec3& x, const dvec3& n);

// Form factor from (x, n) to a distant cell that the receiver's plane does not come near, by the
// point kernel expanded to second order about the cell's centroid: error O((radius / distance)^4)
// of A / (pi r^2) (third order for cells without central symmetry), for a fraction of Lambert's cost.
// Nothing when the expansion does not hold there. Inline: it runs for most cells a receiver visits.
inline std::optional<double> distant_cell_form_factor(const Cell& cell, const dvec3& x, const dvec3& n) {
  // Beyond this many radii the error is below 2e-4 of A / (pi r^2), and over a whole view it
  // partly cancels: a furnace at rho = 0.99 stays within its 0.1%.
  constexpr double kDistantRadii = 8.0;
  constexpr double kPi = 3.14159265358979323846;
  dvec3 d = cell.centroid - x;
  double r2 = glm::dot(d, d);
  if (r2 < kDistantRadii * kDistantRadii * cell.radius * cell.radius) return std::nullopt;
  double g = glm::dot(cell.normal, d);
  if (!(std::fabs(g) > 1e-9 * cell.radius)) return 0.0;  // x in the cell's plane sees it edge-on
  // The corners' heights over the receiver's plane differ from the centroid's by at most the
  // reach times the sine between the planes: beyond that the plane cannot cut the cell.
  double f = glm::dot(n, d);
  double cosine = glm::dot(n, cell.normal);
  if (!(f * f > cell.reach * cell.reach * (1 - cosine * cosine))) return std::nullopt;
  // Farther still, the disc approximation's error, (radius / distance)^2 off the axis, is below
  // 1e-3 and it reads less of the cell: most cells of a fine mesh are this far.
  constexpr double kDiscRadii = 32.0;
  if (r2 > kDiscRadii * kDiscRadii * cell.radius * cell.radius)
    return std::fabs(f * g) * cell.area / (r2 * (kPi * r2 + cell.area));
  // The kernel f g / (pi r^4) (f, g: heights of the point over the planes) integrated to second
  // order, A (K + tr(H M) / 2) with H its Hessian; M lies in the cell's plane, where g is constant.
  // One division serves all the terms.
  dvec3 md = cell.spread * d;
  double trace = cell.spread.trace();
  double inv = 1.0 / (f * r2 * r2);
  double correction = 1 - 2 * trace * f * r2 * inv + 12 * glm::dot(d, md) * f * inv - 4 * glm::dot(n, md) * r2 * inv;
  return std::fabs(f * f * g * inv) * cell.area * correction / kPi;
}

// Splits the bilinear patch p0 p1 p2 p3 (counter-clockwise) into k x k cells at their centres:
// the paper's m x n micro-elements, evaluated by the midpoint rule. Their area moments are left to
// area_moments: the pieces a near cell is split into never need them.
void bilinear_cells(const dvec3 p[4], int k, Cell* out);

// The cell's centroid, reach and second moment (per unit area, in its plane), which
// distant_cell_form_factor reads.
void area_moments(Cell& cell);

// Bilinear interpolation of four corner values at (u, v), corners ordered as the patch.
template <class T>
T bilinear(const T c[4], double u, double v) {
  return (1 - u) * (1 - v) * c[0] + u * (1 - v) * c[1] + u * v * c[2] + (1 - u) * v * c[3];
}

}  // namespace radiosity
