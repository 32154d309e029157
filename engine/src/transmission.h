// Light through transmissive surfaces: what a patch lets through at a crossing, and what the panes
// one ray crosses let through together.
//
// A ray that carries light and meets a pane goes on through it with its light scaled by what the
// pane passes (Visibility's filter records the crossing); rays that ask only whether two places see
// each other treat panes as walls. Light keeps its direction: refraction is not followed.
#pragma once

#include "radiosity/scene.h"

#include <embree3/rtcore.h>

#include <array>
#include <memory>
#include <vector>

namespace radiosity {

// Fresnel reflectance of unpolarised light entering a dielectric of relative index n, at cosine
// cos_i to its normal: the mean of the s and p reflectances.
double fresnel_reflectance(double cos_i, double n);

// Whether two materials differ in a lobe other than reflectance and emission: what passes through
// them or mirrors, which an update does not follow by reflected light alone.
bool optics_differ(const Material& a, const Material& b);

// What a patch passes on without diffusing it: its Material's transmittance at any angle, and its
// glass colour times the part Fresnel lets through at the crossing. In single precision, as rays are.
struct Transmission {
  std::array<float, 3> transmittance{0.0f, 0.0f, 0.0f};
  std::array<float, 3> glass{0.0f, 0.0f, 0.0f};
  float ior = 1.0f;
  // The patch belongs to a single sheet (an open object): a pane, whose two faces one crossing
  // meets, reflecting back and forth between them, so (1 - R) / (1 + R) passes. A closed object's
  // face is one interface: 1 - R, and a ray through it meets another face on the way out. Either
  // interface takes R at the ray's own angle: through parallel faces the light leaves at the angle
  // it came in, and the reflectance out of the glass at the refracted angle is the one into it.
  bool sheet = true;
  // The material's alpha map (null: none) and where the patch's corners read it. The transmittance
  // passes where the surface is not: 1 - alpha at the crossing's place, or 1 - the map's mean where
  // the mesh has no UVs.
  std::shared_ptr<const AlphaMap> alpha;
  std::array<std::array<float, 2>, 4> uv{};
  bool has_uv = false;

  Transmission() = default;
  // `uv`: the patch's four corners' (u, v, 0), or null.
  Transmission(const Material& m, bool sheet, const dvec3* uv = nullptr);
  bool passes() const;  // some channel passes light
  // What passes, per channel, at a crossing at cosine `cos_i` to the normal: on average over the
  // patch (its alpha map's mean), or at Embree's (u, v) on the patch's quad.
  std::array<float, 3> at(double cos_i) const;
  std::array<float, 3> at(double cos_i, float u, float v) const;

 private:
  std::array<float, 3> passing(double cos_i, double open) const;  // transmittance times `open`
};

// The panes each ray of a stream crossed, per ray id (below the capacity it was made for), and what
// they let through together.
class Crossings {
 public:
  // More hits on panes than this on one ray block it (a hit on an edge counts twice): a ray through
  // more than eight panes may be left dark, so the list stays a fixed size per ray.
  static constexpr int kMaxLayers = 16;

  explicit Crossings(unsigned capacity) : rays_(capacity) {}
  // Forgets what the rays of the stream crossed before.
  void clear(const RTCRay* rays, unsigned count) {
    for (unsigned i = 0; i < count; ++i) rays_[rays[i].id].count = 0;
  }
  // Ray `id` crosses `patch` of `object` at parameter t, which passes `rgb`; false if the ray has no
  // room left for it (it is then blocked).
  bool add(unsigned id, float t, int object, int patch, const std::array<float, 3>& rgb);
  // What add() took since the Crossings was made, the cost of panes a solve reports: hits on panes
  // (a ray through an edge meets both quads: two), and rays with one or more, blocked elsewhere or not.
  long long hits() const { return hits_; }
  long long rays_crossing() const { return rays_crossing_; }
  // What the panes `ray` crossed let through together, multiplied in order along the ray (by t, then
  // patch): traversal order, which changes when the scene is rebuilt, does not change a bit. Hits
  // of one object within `eps` (world units) of each other along the ray are one crossing: a ray
  // through an edge or a quad's diagonal is reported by both sides of it.
  dvec3 through(const RTCRay& ray, double eps) const;

 private:
  struct Layer {
    float t;
    int object, patch;
    std::array<float, 3> rgb;
  };
  struct Ray {
    Ray() {}  // the layers stay unwritten until crossed: a batch makes its Crossings often
    int count = 0;
    std::array<Layer, kMaxLayers> layer;
  };
  std::vector<Ray> rays_;
  long long hits_ = 0, rays_crossing_ = 0;
};

}  // namespace radiosity
