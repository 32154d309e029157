#include "radiosity/form_factor.h"

#include "dispatch.h"

#include <algorithm>
#include <cmath>

namespace radiosity {

namespace {

constexpr double kPi = 3.14159265358979323846;

// Edge term of Lambert's formula for vectors a, b from x to the edge's ends: the angle theta the edge
// subtends times the cosine of the edge plane's normal, theta * n.(a x b) / |a x b|.
//
// theta = atan2(|a x b|, a.b) by Cephes' rational atan after reducing to [0, 0.66], to double
// precision. Written without branches and with two divisions (the reduction, and one reciprocal
// that serves both the rational and 1 / |a x b|), so the four edges of a cell overlap: libm's
// atan2, then a branchy version with up to four divisions, were a fifth of a draft solve.
inline double edge_term(const dvec3& n, const dvec3& a, const dvec3& b) {
  dvec3 c = glm::cross(a, b);
  double len = std::sqrt(glm::dot(c, c));
  double y = len, x = glm::dot(a, b);
  double ax = std::fabs(x);
  bool swapped = y > ax;
  double num = swapped ? ax : y, den = swapped ? y : ax;  // t = num / den in [0, 1]
  bool reduced = num > 0.66 * den;                        // then t -> (t - 1) / (t + 1)
  double tn = reduced ? num - den : num, td = reduced ? num + den : den;
  double t = tn / (td > 0 ? td : 1.0);  // td = 0 only with tn = 0
  double z = t * t;
  double p = (((-8.750608600031904122785e-1 * z - 1.615753718733365076637e1) * z -
               7.500855792314704667340e1) * z - 1.228866684490136173410e2) * z - 6.485021904942025371773e1;
  double q = ((((z + 2.485846490142306297962e1) * z + 1.650270098316988542046e2) * z +
               4.328810604912902668951e2) * z + 4.853903996359136964868e2) * z + 1.945506571482613964425e2;
  bool degenerate = !(len > 0.0);  // edge through x or of no length: contributes nothing
  double r = 1.0 / (q * (degenerate ? 1.0 : len));  // p / q = p len r, 1 / len = q r
  double angle = (reduced ? kPi / 4 : 0.0) + t + t * z * p * len * r;
  angle = swapped ? kPi / 2 - angle : angle;
  angle = x < 0 ? kPi - angle : angle;
  return degenerate ? 0.0 : angle * glm::dot(n, c) * (q * r);
}

}  // namespace

RADIOSITY_HOT double polygon_form_factor(const dvec3& x, const dvec3& n, const dvec3* polygon, int count) {
  // Sutherland-Hodgman against the half-space dot(n, r) >= 0, streaming the clipped polygon's
  // vertices straight into the edge sum so any vertex count works without storage.
  double sum = 0.0;
  bool started = false;
  dvec3 first{0.0}, prev{0.0};
  auto emit = [&](const dvec3& p) {
    if (started) sum += edge_term(n, prev, p);
    else first = p, started = true;
    prev = p;
  };
  for (int i = 0; i < count; ++i) {
    dvec3 a = polygon[i] - x;
    dvec3 b = polygon[(i + 1) % count] - x;
    double da = glm::dot(n, a), db = glm::dot(n, b);
    if (da >= 0) emit(a);
    if ((da >= 0) != (db >= 0)) emit(a + (b - a) * (da / (da - db)));
  }
  if (started) sum += edge_term(n, prev, first);
  return std::fabs(sum) / (2.0 * kPi);
}

RADIOSITY_HOT SideFactors cell_form_factor(const Cell& cell, const dvec3& x, const dvec3& n) {
  // Exact for planar cells, so the factors of cells tiling a closed surface sum to one and a furnace
  // converges to E / (1 - rho) however bright; only a cell the receiver's plane cuts needs clipping.
  // A cell in the receiver's own plane gives nothing, whatever the round-off: seen from inside, the
  // formula would count it as the whole hemisphere.
  double tolerance = 1e-9 * cell.radius;
  dvec3 a[4];
  bool above = false, below = false;
  for (int i = 0; i < 4; ++i) {
    a[i] = cell.corners[i] - x;
    double h = glm::dot(n, a[i]);
    above |= h > tolerance;
    below |= h < -tolerance;
  }
  SideFactors f;
  if (above && below) {
    f.front = polygon_form_factor(x, n, cell.corners, 4);
    f.back = polygon_form_factor(x, -n, cell.corners, 4);
  } else if (above || below) {
    // Wholly on one side (nearly every cell): no clipping, and one sum serves either side. The four
    // edge terms are independent and branch-free, so they overlap in the pipeline.
    double term[4];
    for (int i = 0; i < 4; ++i) term[i] = edge_term(n, a[i], a[(i + 1) % 4]);
    (above ? f.front : f.back) = std::fabs(term[0] + term[1] + term[2] + term[3]) / (2.0 * kPi);
  }
  return f;
}

void area_moments(Cell& c) {
  // The two triangles' moments relative to the centre, flattened into the cell's plane.
  dvec3 q[4];
  for (int i = 0; i < 4; ++i) q[i] = c.corners[i] - c.centre;
  double area = 0.0;
  dvec3 first(0.0);
  Symmetric3 second;
  for (int t = 0; t < 2; ++t) {
    const dvec3 &a = q[0], &b = q[t + 1], &e = q[t + 2];
    double at = 0.5 * glm::dot(glm::cross(b - a, e - a), c.normal);
    dvec3 sum = a + b + e;
    area += at;
    first += at * sum / 3.0;
    for (const dvec3& v : {a, b, e, sum}) second.add(Symmetric3::outer(v), at / 12.0);
  }
  dvec3 offset = area > 0 ? first / area : dvec3(0.0);
  c.centroid = c.centre + offset;
  c.reach = 0.0;
  for (const dvec3& p : q) c.reach = std::fmax(c.reach, glm::length(p - offset));
  c.spread = area > 0 ? Symmetric3().add(second, 1 / area).add(Symmetric3::outer(offset), -1).in_plane(c.normal)
                      : Symmetric3();
}

void bilinear_cells(const dvec3 p[4], int k, Cell* out) {
  // Each grid point is evaluated once and shared with the cells before it in the row and the row
  // before: evaluating every cell's four corners afresh was most of splitting a near cell 2 x 2.
  auto at = [&](int i, int j) { return bilinear(p, double(i) / k, double(j) / k); };
  for (int j = 0; j < k; ++j) {
    for (int i = 0; i < k; ++i) {
      Cell& c = out[j * k + i];
      const Cell* left = i > 0 ? &out[j * k + i - 1] : nullptr;
      const Cell* below = j > 0 ? &out[(j - 1) * k + i] : nullptr;
      c.corners[0] = left ? left->corners[1] : below ? below->corners[3] : at(i, j);
      c.corners[1] = below ? below->corners[2] : at(i + 1, j);
      c.corners[2] = at(i + 1, j + 1);
      c.corners[3] = left ? left->corners[2] : at(i, j + 1);
      c.centre = bilinear(p, (i + 0.5) / k, (j + 0.5) / k);
      // Vector area of the cell quad: half the cross product of its diagonals (exact for planar).
      dvec3 va = 0.5 * glm::cross(c.corners[2] - c.corners[0], c.corners[3] - c.corners[1]);
      c.area = glm::length(va);
      c.normal = c.area > 0 ? va / c.area : dvec3(0.0);
      // One square root: it keeps the order of the distances.
      double r2 = 0.0;
      for (const dvec3& q : c.corners) r2 = std::max(r2, glm::dot(q - c.centre, q - c.centre));
      c.radius = std::sqrt(r2);
    }
  }
}

}  // namespace radiosity
