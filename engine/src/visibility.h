// Visibility with Embree: one BVH for the static geometry, one instance per dynamic object (so a
// move is a transform update), and occlusion rays traced in batches.
#pragma once

#include "patch_mesh.h"

#include <embree3/rtcore.h>

#include <memory>
#include <mutex>
#include <vector>

namespace radiosity {

class Visibility {
 public:
  Visibility(const PatchMesh& mesh, const std::vector<bool>& dynamic_objects);
  ~Visibility();
  Visibility(const Visibility&) = delete;
  Visibility& operator=(const Visibility&) = delete;

  // Traces a stream of occlusion rays; an occluded ray comes back with tfar = -inf.
  void occluded(RTCRay* rays, unsigned count) const;

  // Whether points a and b of surfaces with normals na, nb see each other on the side the normals
  // point to. The ends are lifted off their surfaces by more than the surface can bulge between
  // them, so two points of one curved patch do not occlude each other.
  bool connected(const dvec3& a, const dvec3& na, const dvec3& b, const dvec3& nb) const;

  // Benchmark hooks: keep a copy of every `stride`-th traced batch, then trace the copies again with
  // nothing else going on (same scene, same batch size, all cores) and return rays per second.
  void record(int stride);
  double replay_recorded() const;

  // Offset that separates a ray's ends from the surfaces they lie on, relative to the scene size.
  double epsilon() const { return epsilon_; }

 private:
  RTCDevice device_ = nullptr;
  RTCScene top_ = nullptr;
  std::vector<RTCScene> instanced_;
  double epsilon_;
  struct Recording {
    std::mutex mutex;
    int stride = 1;
    long long batches = 0;
    std::vector<std::vector<RTCRay>> batches_kept;
  };
  std::unique_ptr<Recording> recording_;
};

// Collects occlusion rays with the irradiance each carries to a receiving point, traces them in
// streams and adds what arrives unoccluded to the receivers' accumulators (front and back side).
class OcclusionBatch {
 public:
  OcclusionBatch(const Visibility& vis, dvec3* front, dvec3* back) : vis_(vis), front_(front), back_(back) {}
  ~OcclusionBatch() { flush(); }

  // Segment from receiver point x (normal n) to target y; y is pulled off its own surface along
  // target_normal, towards x.
  void to_point(int receiver, const dvec3& x, const dvec3& n, const dvec3& y, const dvec3& target_normal,
                const dvec3& front, const dvec3& back);
  // Ray from x to infinity along dir (sun, sky).
  void to_infinity(int receiver, const dvec3& x, const dvec3& n, const dvec3& dir, const dvec3& front,
                   const dvec3& back);
  void flush();
  long long rays_traced() const { return traced_; }

 private:
  void push(int receiver, const dvec3& origin, const dvec3& dir, float tfar, const dvec3& front,
            const dvec3& back);

  static constexpr unsigned kCapacity = 256;
  const Visibility& vis_;
  dvec3* front_;
  dvec3* back_;
  RTCRay rays_[kCapacity];
  int receiver_[kCapacity];
  dvec3 carried_[kCapacity][2];
  unsigned count_ = 0;
  long long traced_ = 0;
};

}  // namespace radiosity
