#include "lights.h"

#include "place_offset.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace radiosity {

namespace {

constexpr double kPi = 3.14159265358979323846;

// Stratified points on the unit disc: Shirley's concentric map of a k x k grid, one point a cell at
// `offset` within it. The map keeps area, so the cells are equal parts of the disc.
template <class F>
void disc_samples(int samples, PlaceOffset offset, F&& use) {
  int k = std::max(1, int(std::ceil(std::sqrt(double(samples)))));
  for (int j = 0; j < k; ++j)
    for (int i = 0; i < k; ++i) {
      double a = 2.0 * (i + offset.u) / k - 1.0, b = 2.0 * (j + offset.v) / k - 1.0;
      double r = 0.0, phi = 0.0;
      if (std::fabs(a) > std::fabs(b)) r = a, phi = kPi / 4 * (b / a);
      else if (b != 0) r = b, phi = kPi / 2 - kPi / 4 * (a / b);
      use(r * std::cos(phi), r * std::sin(phi), 1.0 / (k * k));
    }
}

void orthonormal_basis(const dvec3& n, dvec3& t, dvec3& b) {
  t = std::fabs(n.x) < 0.9 ? glm::normalize(glm::cross(n, dvec3(1, 0, 0)))
                           : glm::normalize(glm::cross(n, dvec3(0, 1, 0)));
  b = glm::cross(n, t);
}

}  // namespace

double spot_attenuation(const Lamp& lamp, const dvec3& to_receiver_unit) {
  double cos_half = std::cos(0.5 * lamp.spot_size);
  double smooth = (1.0 - cos_half) * lamp.spot_blend;
  double a = glm::dot(glm::normalize(lamp.direction), to_receiver_unit);
  if (a <= cos_half) return 0.0;
  double t = a - cos_half;
  if (t < smooth && smooth != 0.0) {
    double s = t / smooth;
    a *= s * s * (3.0 - 2.0 * s);
  }
  return a;
}

void gather_lamp(const Lamp& lamp, int samples, int receiver, const ReceiverPoint& point,
                 OcclusionBatch& batch) {
  const dvec3& x = point.position;
  const dvec3& n = point.normal;
  if (lamp.type == Lamp::Type::Sun) {
    dvec3 to_sun = -glm::normalize(lamp.direction);
    double cos_r = glm::dot(n, to_sun);
    if (cos_r == 0) return;
    dvec3 h = lamp.color * (std::fabs(cos_r) / kPi);
    bool front = cos_r > 0;
    if (point.enclosed_side == !front) return;  // a closed object's inside: the sun is outside it
    if (lamp.angle <= 0) {
      batch.to_infinity(receiver, x, n, to_sun, front, h);
      return;
    }
    dvec3 t, b;
    orthonormal_basis(to_sun, t, b);
    double spread = std::tan(0.5 * lamp.angle);
    disc_samples(samples, place_offset(x), [&](double u, double v, double w) {
      dvec3 dir = to_sun + spread * (u * t + v * b);
      batch.to_infinity(receiver, x, n, dir, front, w * h);
    });
    return;
  }
  // Point and spot: a disc of lamp.radius facing the receiver.
  dvec3 d = lamp.position - x;
  double dist2 = glm::dot(d, d);
  double dist = std::sqrt(dist2);
  if (dist == 0) return;
  dvec3 to_lamp = d / dist;
  double cos_r = glm::dot(n, to_lamp);
  if (cos_r == 0) return;
  double falloff = lamp.type == Lamp::Type::Spot ? spot_attenuation(lamp, -to_lamp) : 1.0;
  if (falloff == 0) return;
  dvec3 h = lamp.color * (falloff * std::fabs(cos_r) / (kPi * (dist2 + lamp.radius * lamp.radius)));
  bool front = cos_r > 0;
  if (point.enclosed_side == !front &&
      glm::length(lamp.position - point.enclosure.centre) > point.enclosure.radius + lamp.radius)
    return;  // a closed object's inside, and the lamp outside it
  const dvec3 no_normal(0.0);
  if (lamp.radius <= 0) {
    batch.to_point({receiver, x, n}, {lamp.position, no_normal}, front, h);
    return;
  }
  dvec3 t, b;
  orthonormal_basis(to_lamp, t, b);
  disc_samples(samples, place_offset(x), [&](double u, double v, double w) {
    dvec3 y = lamp.position + lamp.radius * (u * t + v * b);
    batch.to_point({receiver, x, n}, {y, no_normal}, front, w * h);
  });
}

// The sky fills the hemisphere where a lamp is a small disc, and seen through a window it is a small
// source at a place not known beforehand: a lamp's count of rays finds it a few times at most, and a
// room's corners far from its window read tens of percent either way. So it takes this many times a
// lamp's rays; those to an open sky end at once, and an unoccluded point's sum is exact at any count.
constexpr int kSkyRaysPerLampRay = 16;

void gather_world(const WorldMap& sky, int samples, int receiver, const ReceiverPoint& point,
                  OcclusionBatch& batch) {
  dvec3 t, b;
  orthonormal_basis(point.normal, t, b);
  // Cosine-weighted directions on each side: every unoccluded ray carries the sky's radiance there
  // over samples (a map's light varies slowly once its suns are lamps: the add-on's export).
  for (int side = 0; side < 2; ++side) {
    if (side == point.enclosed_side) continue;  // a closed object's inside sees no sky
    dvec3 n = side == 0 ? point.normal : -point.normal;
    disc_samples(samples * kSkyRaysPerLampRay, place_offset(point.position), [&](double u, double v, double w) {
      dvec3 dir = u * t + v * b + std::sqrt(std::max(0.0, 1.0 - u * u - v * v)) * n;
      batch.to_infinity(receiver, point.position, point.normal, dir, side == 0, w * sky.at(dir));
    });
  }
}

Shot area_lamp_shot(const Lamp& lamp, int samples) {
  // Quads counter-clockwise seen from the emitting side, -(u x v) for a rectangle, `direction` for a disc.
  std::vector<std::array<dvec3, 4>> quads;
  if (lamp.type == Lamp::Type::Rect) {
    const dvec3 &c = lamp.position, &u = lamp.u_axis, &v = lamp.v_axis;
    quads.push_back({c - u - v, c - u + v, c + u + v, c + u - v});
  } else {
    // A regular 16-gon of the disc's area, as 8 quads fanned from the centre.
    constexpr int kSides = 16;
    dvec3 w = glm::normalize(lamp.direction), t, b;
    orthonormal_basis(w, t, b);
    double r = lamp.radius * std::sqrt(2 * kPi / (kSides * std::sin(2 * kPi / kSides)));
    auto rim = [&](int i) {
      double a = 2 * kPi * i / kSides;
      return lamp.position + r * (std::cos(a) * t + std::sin(a) * b);
    };
    // t x b = w, so the rim runs counter-clockwise seen from the emitting side.
    for (int i = 0; i < kSides; i += 2) quads.push_back({lamp.position, rim(i), rim(i + 1), rim(i + 2)});
  }
  int k = std::max(1, int(std::ceil(std::sqrt(double(samples) / quads.size()))));
  Shot shot;
  ShotElement e;
  std::vector<Cell> cells(k * k);
  const std::vector<uint8_t> all_corners(k * k, 15);
  const std::vector<uint8_t>* seen[2] = {&all_corners, nullptr};  // it emits from its front only
  for (const auto& q : quads) {
    ShotPatch patch;
    for (int c = 0; c < 4; ++c) patch.corner[c] = q[c], patch.radiance[c][0] = lamp.color, patch.radiance[c][1] = dvec3(0.0);
    bilinear_cells(q.data(), k, cells.data());
    add_patch(shot, patch, cells, k, seen);
  }
  e.cell_end = int(shot.cells.size());
  shot.elements.push_back(e);
  set_frontier(shot, {0});
  shot.ends_by_place = true;  // a lamp is often seen through a window
  return shot;
}

}  // namespace radiosity
