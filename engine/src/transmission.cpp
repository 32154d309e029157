#include "transmission.h"

#include <algorithm>
#include <cmath>

namespace radiosity {

double fresnel_reflectance(double cos_i, double n) {
  if (n == 1.0) return 0.0;
  cos_i = std::fabs(cos_i);
  if (!(cos_i > 0.0)) return 1.0;  // grazing: all of it (also for a degenerate triangle's normal)
  cos_i = std::min(cos_i, 1.0);
  double cos_t = std::sqrt(1.0 - (1.0 - cos_i * cos_i) / (n * n));  // n > 1: entering, always refracts
  double rs = (cos_i - n * cos_t) / (cos_i + n * cos_t);
  double rp = (cos_t - n * cos_i) / (cos_t + n * cos_i);
  return 0.5 * (rs * rs + rp * rp);
}

bool optics_differ(const Material& a, const Material& b) {
  bool same_alpha = a.alpha == b.alpha || (a.alpha && b.alpha && *a.alpha == *b.alpha);
  return a.transmittance != b.transmittance || a.glass != b.glass || a.ior != b.ior || a.specular != b.specular ||
         a.roughness != b.roughness || !same_alpha;
}

Transmission::Transmission(const Material& m, bool sheet, const dvec3* corner_uv)
    : ior(float(m.ior)), sheet(sheet), alpha(m.alpha), has_uv(m.alpha && corner_uv) {
  for (int k = 0; k < 3; ++k) transmittance[k] = float(m.transmittance[k]), glass[k] = float(m.glass[k]);
  if (has_uv)
    for (int c = 0; c < 4; ++c) uv[c] = {float(corner_uv[c].x), float(corner_uv[c].y)};
}

bool Transmission::passes() const {
  for (int k = 0; k < 3; ++k)
    if (transmittance[k] > 0 || glass[k] > 0) return true;
  return false;
}

std::array<float, 3> Transmission::at(double cos_i) const { return passing(cos_i, alpha ? 1.0 - alpha->mean() : 1.0); }

std::array<float, 3> Transmission::at(double cos_i, float u, float v) const {
  if (!has_uv) return at(cos_i);
  // Embree parametrises a quad as the bilinear patch of its corners: so are the corners' UVs read.
  float tu = (1 - u) * (1 - v) * uv[0][0] + u * (1 - v) * uv[1][0] + u * v * uv[2][0] + (1 - u) * v * uv[3][0];
  float tv = (1 - u) * (1 - v) * uv[0][1] + u * (1 - v) * uv[1][1] + u * v * uv[2][1] + (1 - u) * v * uv[3][1];
  return passing(cos_i, 1.0 - alpha->at(tu, tv));
}

std::array<float, 3> Transmission::passing(double cos_i, double open) const {
  double pass = 0.0;
  if (glass[0] > 0 || glass[1] > 0 || glass[2] > 0) {
    double r = fresnel_reflectance(cos_i, ior);
    pass = sheet ? (1.0 - r) / (1.0 + r) : 1.0 - r;
  }
  std::array<float, 3> rgb;
  for (int k = 0; k < 3; ++k) rgb[k] = float(open * transmittance[k] + glass[k] * pass);
  return rgb;
}

bool Crossings::add(unsigned id, float t, int object, int patch, const std::array<float, 3>& rgb) {
  Ray& r = rays_[id];
  if (r.count == kMaxLayers) return false;
  rays_crossing_ += r.count == 0;
  ++hits_;
  r.layer[r.count++] = {t, object, patch, rgb};
  return true;
}

dvec3 Crossings::through(const RTCRay& ray, double eps) const {
  const Ray& r = rays_[ray.id];
  if (r.count == 0) return dvec3(1.0);
  std::array<const Layer*, kMaxLayers> order;
  for (int i = 0; i < r.count; ++i) order[i] = &r.layer[i];
  std::sort(order.begin(), order.begin() + r.count, [](const Layer* a, const Layer* b) {
    return a->t < b->t || (a->t == b->t && a->patch < b->patch);
  });
  double same = eps / std::sqrt(double(ray.dir_x) * ray.dir_x + double(ray.dir_y) * ray.dir_y +
                                double(ray.dir_z) * ray.dir_z);
  dvec3 product(1.0);
  const Layer* crossing = nullptr;  // the first hit of the crossing the hits belong to
  for (int i = 0; i < r.count; ++i) {
    const Layer& l = *order[i];
    if (crossing && l.object == crossing->object && double(l.t) - crossing->t <= same) continue;
    crossing = &l;
    product *= dvec3(l.rgb[0], l.rgb[1], l.rgb[2]);
  }
  return product;
}

}  // namespace radiosity
