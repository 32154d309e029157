#include "corner_view.h"

#include <algorithm>
#include <cmath>

namespace radiosity {

namespace {

// Per facet corner: the curved furnace (test_module.py) moves by 0.02% from 16 to 32.
constexpr int kAzimuthSteps = 16;

// A patch corner's facet: the plane of its two edges at the corner.
struct CornerFacet {
  dvec3 normal{0.0};  // unit; zero if the edges are parallel
  double azimuth = 0.0, width = 0.0;  // the corner's angle, projected on the point's tangent plane
};

// The part of the cosine-weighted hemisphere about `shading` above a facet of normal `facet`
// (neither need be unit; 1 if either is zero): (1 + cos tilt) / 2.
double share_above(const dvec3& facet, const dvec3& shading) {
  double lengths = glm::length(facet) * glm::length(shading);
  return lengths > 0 ? 0.5 * (1.0 + std::clamp(glm::dot(facet, shading) / lengths, -1.0, 1.0)) : 1.0;
}

}  // namespace

double interior_share(const dvec3 corner[4], const dvec3 normal[4]) {
  // Midpoint rule on 4 x 4: the integrand is smooth, and flat at 1 where the normals agree.
  constexpr int k = 4;
  double sum = 0.0;
  for (int j = 0; j < k; ++j)
    for (int i = 0; i < k; ++i) {
      double u = (i + 0.5) / k, v = (j + 0.5) / k;
      dvec3 du = (1 - v) * (corner[1] - corner[0]) + v * (corner[2] - corner[3]);
      dvec3 dv = (1 - u) * (corner[3] - corner[0]) + u * (corner[2] - corner[1]);
      dvec3 shading = (1 - u) * (1 - v) * normal[0] + u * (1 - v) * normal[1] + u * v * normal[2] + (1 - u) * v * normal[3];
      sum += share_above(glm::cross(du, dv), shading);
    }
  return sum / (k * k);
}

CornerView corner_view(const PatchMesh& pm, int p, const dvec3* corner_normal, int first_slot) {
  const ReceiverPoint& rp = pm.points[p];
  int begin = pm.point_slot_begin[p], end = pm.point_slot_begin[p + 1];
  CornerView view;
  view.own.assign(end - begin, {0.0, 0.0});
  view.onward.assign(end - begin, 1.0);
  dvec3 n = rp.normal;
  if (n == dvec3(0.0)) return view;
  dvec3 t1 = glm::normalize(std::fabs(n.x) < 0.9 ? glm::cross(n, dvec3(1, 0, 0)) : glm::cross(n, dvec3(0, 1, 0)));
  dvec3 t2 = glm::cross(n, t1);
  auto azimuth = [&](const dvec3& d) { return std::atan2(glm::dot(d, t2), glm::dot(d, t1)); };

  std::vector<CornerFacet> facets(end - begin);
  std::vector<int> live;  // slots of patches with area
  double share_sum = 0.0;
  bool smooth = false;
  for (int i = begin; i < end; ++i) {
    int slot = pm.point_slots[i];
    const Patch& patch = pm.patches[slot / 4];
    if (patch.area == 0) continue;
    int c = slot % 4;
    const dvec3& at = pm.vertices[patch.vertex[c]];
    dvec3 next = pm.vertices[patch.vertex[(c + 1) % 4]] - at, prev = pm.vertices[patch.vertex[(c + 3) % 4]] - at;
    CornerFacet& f = facets[i - begin];
    dvec3 m = glm::cross(next, prev);
    if (glm::length(m) > 0) f.normal = glm::normalize(m);
    // Counter-clockwise about the normal from the edge to the next corner to the edge to the
    // previous one: the corner's inside.
    f.azimuth = azimuth(next);
    f.width = std::fmod(azimuth(prev) - f.azimuth + 4 * M_PI, 2 * M_PI);
    const dvec3& shading = corner_normal[slot - first_slot];
    smooth |= shading != patch.normal;
    double share = shading == patch.normal ? 1.0 : share_above(f.normal, shading);
    share_sum += share;
    // A corner whose shading normal turns more than a right angle from its facet (a mesh whose faces
    // disagree on which side is the front) keeps a share below a half: divided by it, what the point
    // takes at close range without the share (own) would be sent on many times over, and the solve
    // diverge to inf.
    view.onward[i - begin] = patch.interior_share / std::max(share, 0.5);
    live.push_back(i - begin);
  }
  if (live.empty()) return view;
  double share = share_sum / live.size();
  view.reflected_share = {share, share};
  if (!smooth) return view;  // flat: the patches it lies on are its tangent plane

  // Along each azimuth of each facet corner, per side: the directions under that facet (which it
  // shows the point at close range) and above each corner's facet (which Cycles keeps there). The
  // back side sees the same planes from the other pole: the same heights, the other sign.
  size_t count = live.size();
  std::vector<double> rise(count), along(count);  // a facet normal's height over the pole; along u
  for (size_t f = 0; f < count; ++f) rise[f] = std::max(glm::dot(n, facets[live[f]].normal), 1e-9);
  // Along azimuth u, the part of the view from where the facet's plane passes over it to the horizon.
  auto under = [&](size_t f, double sign) {
    double b = sign * along[f];
    return b < 0 ? b * b / (rise[f] * rise[f] + b * b) : 0.0;
  };
  std::array<double, 2> hidden{0.0, 0.0}, own_sum{0.0, 0.0};
  for (size_t j = 0; j < count; ++j) {
    const CornerFacet& fj = facets[live[j]];
    if (fj.normal == dvec3(0.0)) continue;
    double step = fj.width / kAzimuthSteps, weight = step / (2 * M_PI);
    std::array<double, 2> seen{0.0, 0.0};
    for (int k = 0; k < kAzimuthSteps; ++k) {
      double phi = fj.azimuth + (k + 0.5) * step;
      dvec3 u = std::cos(phi) * t1 + std::sin(phi) * t2;
      for (size_t f = 0; f < count; ++f) along[f] = glm::dot(u, facets[live[f]].normal);
      for (int side = 0; side < 2; ++side) {
        double sign = side == 0 ? 1.0 : -1.0;
        double below = under(j, sign);
        if (below == 0) continue;
        hidden[side] += below * weight;
        for (size_t f = 0; f < count; ++f) seen[side] += std::max(0.0, below - under(f, sign)) * weight;
      }
    }
    for (int side = 0; side < 2; ++side) {
      view.own[live[j]][side] = seen[side] / count;
      own_sum[side] += view.own[live[j]][side];
    }
  }
  // What the point gathers from beyond its own patches fills 1 - hidden of its view; the corners
  // take share - own_sum of the whole, spread as that light is.
  for (int side = 0; side < 2; ++side)
    view.reflected_share[side] = std::clamp((share - own_sum[side]) / std::max(1.0 - hidden[side], 1e-3), 0.0, 1.0);
  return view;
}

}  // namespace radiosity
