// Point-to-element form factors: the integrand of the radiosity equation without visibility.
//
// A receiving point has two sides (Cycles' surfaces are two-sided), so every factor comes as the
// part seen by the hemisphere around +n (front) and the part seen around -n (back).
#pragma once

#include "radiosity/lanes.h"

#include <glm/glm.hpp>

#include <cmath>
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

// A symmetric 3 x 3 matrix: six numbers where a dmat3 holds nine. Of doubles, or of Lanes (four
// matrices) for the form factors of four elements at once; only the products are generic.
template <class R>
struct SymmetricOf {
  R xx{}, yy{}, zz{}, xy{}, xz{}, yz{};
  template <class V>
  V operator*(const V& v) const {
    return V{xx * v.x + xy * v.y + xz * v.z, xy * v.x + yy * v.y + yz * v.z, xz * v.x + yz * v.y + zz * v.z};
  }
  R trace() const { return xx + yy + zz; }
  static SymmetricOf outer(const dvec3& v) {
    return {v.x * v.x, v.y * v.y, v.z * v.z, v.x * v.y, v.x * v.z, v.y * v.z};
  }
  SymmetricOf& add(const SymmetricOf& o, double weight) {
    xx += weight * o.xx, yy += weight * o.yy, zz += weight * o.zz;
    xy += weight * o.xy, xz += weight * o.xz, yz += weight * o.yz;
    return *this;
  }
  // P M P, P the projection onto the plane normal to unit n: the moment flattened into that plane.
  SymmetricOf in_plane(const dvec3& n) const {
    dvec3 mn = *this * n;  // P M P = M - n (Mn)^T - (Mn) n^T + (n.Mn) n n^T
    SymmetricOf out = *this;
    out.xx -= 2 * n.x * mn.x, out.yy -= 2 * n.y * mn.y, out.zz -= 2 * n.z * mn.z;
    out.xy -= n.x * mn.y + mn.x * n.y, out.xz -= n.x * mn.z + mn.x * n.z, out.yz -= n.y * mn.z + mn.y * n.z;
    return out.add(outer(n), glm::dot(n, mn));
  }
};
using Symmetric3 = SymmetricOf<double>;

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

// The point kernel f g / (pi r^4) integrated to second order over a flat element of `area` whose
// second moment about its centroid (per unit area, in its plane, where g is constant) is `spread`:
// A (K + tr(H M) / 2), H the kernel's Hessian. d runs from the receiver (x, n) to the centroid, f and
// g are the heights n.d and m.d. Valid where the receiver's plane does not cut the element. One
// division serves all the terms. This and the two below run on doubles or on Lanes (lanes.h).
template <class V, class R, class S>
RADIOSITY_LANES R expanded_form_factor(const V& d, R r2, R f, R g, R area, const S& spread, const V& n) {
  constexpr double kPi = 3.14159265358979323846;
  V md = spread * d;
  R inv = 1.0 / (f * r2 * r2);
  R correction = 1 - 2 * spread.trace() * f * r2 * inv + 12 * dot(d, md) * f * inv - 4 * dot(n, md) * r2 * inv;
  return magnitude(f * f * g * inv) * area * correction / kPi;
}

// The disc approximation of the same, right on the axis of a disc: the bare point kernel
// A / (pi r^2) overshoots there by (R / r)^2. One division.
template <class R>
RADIOSITY_LANES R disc_form_factor(R r2, R f, R g, R area) {
  constexpr double kPi = 3.14159265358979323846;
  return magnitude(f * g) * area / (r2 * (kPi * r2 + area));
}

// Whether the receiver's plane (x, n) stays clear of an element of `reach` about its centroid, d
// away, facing `normal`: the element's points' heights over the plane differ from the centroid's,
// f = n.d, by at most the reach times the sine between the planes.
template <class V, class R>
RADIOSITY_LANES auto clear_of_plane(const V& n, const V& normal, R f, R reach) {
  R cosine = dot(n, normal);
  return f * f > reach * reach * (1 - cosine * cosine);
}

// Form factor from (x, n) to a distant cell that the receiver's plane does not come near, by the
// point kernel expanded to second order about the cell's centroid: error O((radius / distance)^4)
// of A / (pi r^2) (third order for cells without central symmetry), for a fraction of Lambert's cost.
// Nothing when the expansion does not hold there. Forced inline: it runs for most cells a receiver
// visits, and GCC's heuristics leave it out of line (in the baseline ISA, dispatch.h).
__attribute__((always_inline)) inline std::optional<double> distant_cell_form_factor(const Cell& cell, const dvec3& x, const dvec3& n) {
  // Beyond this many radii the error is below 2e-4 of A / (pi r^2), and over a whole view it
  // partly cancels: a furnace at rho = 0.99 stays within its 0.1%.
  constexpr double kDistantRadii = 8.0;
  dvec3 d = cell.centroid - x;
  double r2 = glm::dot(d, d);
  if (r2 < kDistantRadii * kDistantRadii * cell.radius * cell.radius) return std::nullopt;
  double g = glm::dot(cell.normal, d);
  if (!(std::fabs(g) > 1e-9 * cell.radius)) return 0.0;  // x in the cell's plane sees it edge-on
  double f = glm::dot(n, d);
  if (!clear_of_plane(n, cell.normal, f, cell.reach)) return std::nullopt;
  // Farther still, the disc approximation's error, (radius / distance)^2 off the axis, is below
  // 1e-3 and it reads less of the cell: most cells of a fine mesh are this far.
  constexpr double kDiscRadii = 32.0;
  if (r2 > kDiscRadii * kDiscRadii * cell.radius * cell.radius)
    return disc_form_factor(r2, f, g, cell.area);
  return expanded_form_factor(d, r2, f, g, cell.area, cell.spread, n);
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

// At (u, v) the bilinear patch c0 c1 c2 c3 lies u v T off the triangle (c0, c1, c3) Embree traces
// for it (u + v <= 1), and (1 - u) (1 - v) T off (c2, c3, c1), T = c0 - c1 + c2 - c3. A ray ending
// on the patch short of that could end behind the triangles and count as blocked. Its twist: how
// far along the unit `normal` a point must move per unit of that weight to come out in front of
// both triangles' planes.
inline double bilinear_twist(const dvec3 c[4], const dvec3& normal) {
  dvec3 t = c[0] - c[1] + c[2] - c[3];
  double twist = std::fabs(glm::dot(t, normal));
  for (dvec3 facing : {glm::cross(c[1] - c[0], c[3] - c[0]), glm::cross(c[3] - c[2], c[1] - c[2])}) {
    double length = glm::length(facing);
    if (length > 0) twist = std::max(twist, std::fabs(glm::dot(t, facing)) / std::max(glm::dot(normal, facing), 0.5 * length));
  }
  return twist;
}

// How far to lift a ray's end at (u, v) of a patch of that twist off it: twice the need, for the
// tilt of the cells' own normals and Embree's float.
inline double bilinear_lift(double twist, double u, double v) {
  return 2 * twist * (u + v <= 1 ? u * v : (1 - u) * (1 - v));
}

// The most it lies off them: at its centre.
inline double bilinear_bulge(double twist) { return 0.25 * twist; }
inline double bilinear_bulge(const dvec3 c[4], const dvec3& normal) { return bilinear_bulge(bilinear_twist(c, normal)); }

}  // namespace radiosity
