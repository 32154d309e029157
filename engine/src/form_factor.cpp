#include "radiosity/form_factor.h"

#include "dispatch.h"

#include <algorithm>
#include <cmath>

#include <emmintrin.h>

// The double4 helpers below are inlined, so no vector crosses a call: GCC's warning that AVX vectors
// are returned otherwise without AVX does not apply.
#pragma GCC diagnostic ignored "-Wpsabi"

namespace radiosity {

namespace {

constexpr double kPi = 3.14159265358979323846;

// The four edges of a cell side by side, a lane each (GCC's vector extension: one instruction
// per operation in the AVX2 clones, two in the SSE2 ones). Each lane does exactly what one edge
// does alone, to the last bit.
using double4 = double __attribute__((vector_size(32)));
using long4 = decltype(double4{} < double4{});  // a lane's comparison: all ones or zero
struct Edges {  // four 3-vectors, one per lane
  double4 x, y, z;
};

// What edge_term needs of one edge (double) or of four (double4).
inline double root(double v) { return std::sqrt(v); }
// Two SSE2 square roots of two lanes each (baseline ISA too): std::sqrt lane by lane also tests
// each for a negative (errno), in the cell's hot path. IEEE square roots: the same bits.
inline double4 root(const double4& v) {
  __m128d lo = _mm_sqrt_pd(_mm_set_pd(v[1], v[0])), hi = _mm_sqrt_pd(_mm_set_pd(v[3], v[2]));
  return double4{_mm_cvtsd_f64(lo), _mm_cvtsd_f64(_mm_unpackhi_pd(lo, lo)), _mm_cvtsd_f64(hi),
                 _mm_cvtsd_f64(_mm_unpackhi_pd(hi, hi))};
}
inline double magnitude(double v) { return std::fabs(v); }
inline double4 magnitude(const double4& v) { return double4(long4(v) & 0x7fffffffffffffffLL); }
inline double pick(bool m, double a, double b) { return m ? a : b; }
inline double4 pick(const long4& m, const double4& a, const double4& b) { return m ? a : b; }

// Edge term of Lambert's formula for vectors a, b from x to the edge's ends: the angle theta the edge
// subtends times the cosine of the edge plane's normal, theta * n.(a x b) / |a x b|.
//
// theta = atan2(|a x b|, a.b) by Cephes' rational atan after reducing to [0, 0.66], to double
// precision. Written without branches and with two divisions (the reduction, and one reciprocal
// that serves both the rational and 1 / |a x b|), so the four edges of a cell overlap rather than
// wait on libm's atan2 and its divisions in the hottest loop of a solve. A cell wholly on one side
// of the receiver's plane takes its four edges at once (T = double4): a third of the instructions
// of four edges one by one.
template <class T, class V>
inline T edge_term(const V& n, const V& a, const V& b) {
  const T one = T{} + 1.0, zero = T{} + 0.0;
  T cx = a.y * b.z - b.y * a.z, cy = a.z * b.x - b.z * a.x, cz = a.x * b.y - b.x * a.y;  // a x b
  T len = root(cx * cx + cy * cy + cz * cz);
  T y = len, x = a.x * b.x + a.y * b.y + a.z * b.z;
  T ax = magnitude(x);
  auto swapped = y > ax;
  T num = pick(swapped, ax, y), den = pick(swapped, y, ax);  // t = num / den in [0, 1]
  auto reduced = num > 0.66 * den;                           // then t -> (t - 1) / (t + 1)
  T tn = pick(reduced, num - den, num), td = pick(reduced, num + den, den);
  T t = tn / pick(td > 0, td, one);  // td = 0 only with tn = 0
  T z = t * t;
  T p = (((-8.750608600031904122785e-1 * z - 1.615753718733365076637e1) * z -
          7.500855792314704667340e1) * z - 1.228866684490136173410e2) * z - 6.485021904942025371773e1;
  T q = ((((z + 2.485846490142306297962e1) * z + 1.650270098316988542046e2) * z +
          4.328810604912902668951e2) * z + 4.853903996359136964868e2) * z + 1.945506571482613964425e2;
  auto positive = len > 0.0;  // else the edge runs through x or has no length: it contributes nothing
  T r = 1.0 / (q * pick(positive, len, one));  // p / q = p len r, 1 / len = q r
  T angle = pick(reduced, T{} + kPi / 4, zero) + t + t * z * p * len * r;
  angle = pick(swapped, kPi / 2 - angle, angle);
  angle = pick(x < 0, kPi - angle, angle);
  return pick(positive, angle * (n.x * cx + n.y * cy + n.z * cz) * (q * r), zero);
}

}  // namespace

RADIOSITY_HOT double polygon_form_factor(const dvec3& x, const dvec3& n, const dvec3* polygon, int count) {
  // Sutherland-Hodgman against the half-space dot(n, r) >= 0, streaming the clipped polygon's
  // vertices straight into the edge sum so any vertex count works without storage.
  double sum = 0.0;
  bool started = false;
  dvec3 first{0.0}, prev{0.0};
  auto emit = [&](const dvec3& p) {
    if (started) sum += edge_term<double>(n, prev, p);
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
  if (started) sum += edge_term<double>(n, prev, first);
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
    // edge terms are independent and branch-free: one lane each.
    Edges from{{a[0].x, a[1].x, a[2].x, a[3].x}, {a[0].y, a[1].y, a[2].y, a[3].y}, {a[0].z, a[1].z, a[2].z, a[3].z}};
    Edges to{{a[1].x, a[2].x, a[3].x, a[0].x}, {a[1].y, a[2].y, a[3].y, a[0].y}, {a[1].z, a[2].z, a[3].z, a[0].z}};
    Edges normal{double4{} + n.x, double4{} + n.y, double4{} + n.z};
    double4 term = edge_term<double4>(normal, from, to);
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
  // before: evaluating every cell's four corners afresh would be most of splitting a near cell 2 x 2.
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
