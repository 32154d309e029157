#include "radiosity/form_factor.h"

#include <cmath>

namespace radiosity {

namespace {

constexpr double kPi = 3.14159265358979323846;

// atan2(y, x) for y >= 0, to double precision (Cephes' rational atan after reducing to [0, 0.66]).
// libm's general atan2 was a sixth of a solve; this is the form factor's inner loop.
double angle(double y, double x) {
  double ax = std::fabs(x);
  bool swapped = y > ax;
  double t = swapped ? ax / y : (ax > 0 ? y / ax : 0.0);
  double base = 0.0;
  if (t > 0.66) {
    base = kPi / 4;
    t = (t - 1) / (t + 1);
  }
  double z = t * t;
  double p = (((-8.750608600031904122785e-1 * z - 1.615753718733365076637e1) * z -
               7.500855792314704667340e1) * z - 1.228866684490136173410e2) * z - 6.485021904942025371773e1;
  double q = ((((z + 2.485846490142306297962e1) * z + 1.650270098316988542046e2) * z +
               4.328810604912902668951e2) * z + 4.853903996359136964868e2) * z + 1.945506571482613964425e2;
  double a = base + t + t * z * p / q;
  if (swapped) a = kPi / 2 - a;
  return x < 0 ? kPi - a : a;
}

// Edge term of Lambert's formula: angle subtended times the cosine of the edge plane's normal.
double edge_term(const dvec3& n, const dvec3& a, const dvec3& b) {
  dvec3 c = glm::cross(a, b);
  double len = glm::length(c);
  if (len <= 0.0) return 0.0;  // edge through x or degenerate: contributes nothing
  return angle(len, glm::dot(a, b)) * glm::dot(n, c) / len;
}

}  // namespace

double polygon_form_factor(const dvec3& x, const dvec3& n, const dvec3* polygon, int count) {
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

SideFactors cell_form_factor(const Cell& cell, const dvec3& x, const dvec3& n) {
  // Exact for planar cells, so the factors of cells tiling a closed surface sum to one and a furnace
  // converges to E / (1 - rho) however bright; only a cell the receiver's plane cuts needs clipping.
  // A cell in the receiver's own plane gives nothing, whatever the round-off: seen from inside, the
  // formula would count it as the whole hemisphere.
  double tolerance = 1e-9 * cell.radius;
  bool above = false, below = false;
  for (const dvec3& c : cell.corners) {
    double h = glm::dot(n, c - x);
    above |= h > tolerance;
    below |= h < -tolerance;
  }
  SideFactors f;
  if (above) f.front = polygon_form_factor(x, n, cell.corners, 4);
  if (below) f.back = polygon_form_factor(x, -n, cell.corners, 4);
  return f;
}

void bilinear_cells(const dvec3 p[4], int k, Cell* out) {
  double h = 1.0 / k;
  for (int j = 0; j < k; ++j) {
    for (int i = 0; i < k; ++i) {
      Cell& c = out[j * k + i];
      double u0 = i * h, v0 = j * h;
      c.corners[0] = bilinear(p, u0, v0);
      c.corners[1] = bilinear(p, u0 + h, v0);
      c.corners[2] = bilinear(p, u0 + h, v0 + h);
      c.corners[3] = bilinear(p, u0, v0 + h);
      c.centre = bilinear(p, u0 + 0.5 * h, v0 + 0.5 * h);
      // Vector area of the cell quad: half the cross product of its diagonals (exact for planar).
      dvec3 va = 0.5 * glm::cross(c.corners[2] - c.corners[0], c.corners[3] - c.corners[1]);
      c.area = glm::length(va);
      c.normal = c.area > 0 ? va / c.area : dvec3(0.0);
      c.radius = 0.0;
      for (const dvec3& q : c.corners) c.radius = std::fmax(c.radius, glm::length(q - c.centre));
    }
  }
}

}  // namespace radiosity
