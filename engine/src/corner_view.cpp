#include "corner_view.h"

#include <algorithm>
#include <cmath>

namespace radiosity {

namespace {

constexpr int kAzimuthSteps = 32;  // per facet corner: the integrands are smooth in azimuth

// A patch corner's facet: the plane of its two edges at the corner.
struct Facet {
  dvec3 normal{0.0};  // unit; zero if the edges are parallel
  double azimuth = 0.0, width = 0.0;  // the corner's angle, projected on the point's tangent plane
};

// Directions about `pole` at azimuth u (unit, in the tangent plane) lie under the plane through
// the point with unit normal m from some elevation on (if at all); of the cosine-weighted view
// along that azimuth, the part from there to the horizon is cos^2 of that elevation angle:
// a cos t + b sin t < 0 beyond tan t = a / -b.
double under(const dvec3& pole, const dvec3& m, const dvec3& u) {
  double a = std::max(glm::dot(pole, m), 1e-9), b = glm::dot(u, m);
  return b < 0 ? b * b / (a * a + b * b) : 0.0;
}

// The part of the cosine-weighted hemisphere about `shading` above the facet: (1 + cos tilt) / 2.
double share_above(const Facet& f, const dvec3& shading) {
  return f.normal == dvec3(0.0) ? 1.0 : 0.5 * (1.0 + std::clamp(glm::dot(f.normal, shading), -1.0, 1.0));
}

}  // namespace

CornerView corner_view(const PatchMesh& pm, int p, const dvec3* corner_normal, int first_slot) {
  const ReceiverPoint& rp = pm.points[p];
  int begin = pm.point_slot_begin[p], end = pm.point_slot_begin[p + 1];
  CornerView view;
  view.own.assign(end - begin, {0.0, 0.0});
  dvec3 n = rp.normal;
  if (n == dvec3(0.0)) return view;
  dvec3 t1 = glm::normalize(std::fabs(n.x) < 0.9 ? glm::cross(n, dvec3(1, 0, 0)) : glm::cross(n, dvec3(0, 1, 0)));
  dvec3 t2 = glm::cross(n, t1);
  auto azimuth = [&](const dvec3& d) { return std::atan2(glm::dot(d, t2), glm::dot(d, t1)); };

  std::vector<Facet> facets(end - begin);
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
    Facet& f = facets[i - begin];
    dvec3 m = glm::cross(next, prev);
    if (glm::length(m) > 0) f.normal = glm::normalize(m);
    // Counter-clockwise about the normal from the edge to the next corner to the edge to the
    // previous one: the corner's inside.
    f.azimuth = azimuth(next);
    f.width = std::fmod(azimuth(prev) - f.azimuth + 4 * M_PI, 2 * M_PI);
    const dvec3& shading = corner_normal[slot - first_slot];
    smooth |= shading != patch.normal;
    share_sum += shading == patch.normal ? 1.0 : share_above(f, shading);
    live.push_back(i - begin);
  }
  if (live.empty()) return view;
  double share = share_sum / live.size();
  view.reflected_share = {share, share};
  if (!smooth) return view;  // flat: the patches it lies on are its tangent plane

  // Per side, along each azimuth of each facet corner: the directions under that facet (which it
  // shows the point at close range) and above each corner's facet (which Cycles keeps there).
  std::vector<double> seen_by(live.size());
  for (int side = 0; side < 2; ++side) {
    dvec3 pole = side == 0 ? n : -n;
    double sign = side == 0 ? 1.0 : -1.0;
    double hidden = 0.0, own_sum = 0.0;
    for (int j : live) {
      const Facet& fj = facets[j];
      if (fj.normal == dvec3(0.0)) continue;
      double step = fj.width / kAzimuthSteps;
      std::fill(seen_by.begin(), seen_by.end(), 0.0);
      for (int k = 0; k < kAzimuthSteps; ++k) {
        double phi = fj.azimuth + (k + 0.5) * step;
        dvec3 u = std::cos(phi) * t1 + std::sin(phi) * t2;
        double below = under(pole, sign * fj.normal, u);
        if (below == 0) continue;
        hidden += below * step / (2 * M_PI);
        for (size_t f = 0; f < live.size(); ++f) {
          const Facet& ff = facets[live[f]];
          double cut = ff.normal == dvec3(0.0) ? 0.0 : under(pole, sign * ff.normal, u);
          seen_by[f] += std::max(0.0, below - cut) * step / (2 * M_PI);
        }
      }
      double mean = 0.0;
      for (double s : seen_by) mean += s;
      view.own[j][side] = mean / live.size();
      own_sum += view.own[j][side];
    }
    // What the point gathers from beyond its own patches fills 1 - hidden of its view; the
    // corners take share - own_sum of the whole, spread as that light is.
    view.reflected_share[side] = std::clamp((share - own_sum) / std::max(1.0 - hidden, 1e-3), 0.0, 1.0);
  }
  return view;
}

}  // namespace radiosity
