// A batch of occlusion rays: what a gather collects, traced in streams.
#pragma once

#include "bounds.h"
#include "changed_rays.h"
#include "visibility.h"

#include <algorithm>
#include <array>
#include <iterator>
#include <memory>

namespace radiosity {

class MirrorPlane;

// The receiving end of a ray: the receiver (the index of its light's sum), its position and normal.
struct RayStart {
  int receiver;
  const dvec3& x;
  const dvec3& n;
};

// The far end of a segment: the target point y on a surface with normal `normal`, which may lie
// `lift` off the surface that is traced for it; with `under_patch`, y lies on that patch, which may
// lie under another surface (Visibility::may_lie_under), and the segment is traced as Coincident says.
struct RayEnd {
  const dvec3& y;
  const dvec3& normal;
  double lift = 0.0;
  int under_patch = -1;
};

// Collects occlusion rays with the irradiance each carries to one side of a receiving point, traces them in
// streams and adds what arrives unoccluded to the receivers' accumulators (front and back side). In a
// scene where some patch lets light through, a ray goes on through such patches and adds what they
// let through (Crossings); else rays are traced and added as if no pane could exist.
//
// While a mirror is set, rays aim at a mirrored image: each becomes a two-leg path by way of the
// mirror (set_mirror), and light adds where both legs are clear.
//
// With ChangedRays, a batch carries only what one object's last move changed (changed_rays.h): it
// leaves out, as they come, the rays that cannot have changed, and has the rest sifted and traced
// there; light that reaches a receiver without a ray cannot have changed either.
class OcclusionBatch {
 public:
  // The accumulators hold receivers from `first_receiver` on: points that are not receiving points
  // (pieces of a patch) gather under indices past the last one, into arrays of their own.
  OcclusionBatch(const Visibility& vis, dvec3* front, dvec3* back, int first_receiver = 0)
      : vis_(vis), front_(front), back_(back), first_(first_receiver) {
    // Tracing changes only tfar: the fields every ray shares are written once, not once a ray. A
    // ray's id is its slot, where its Coincident data is.
    for (unsigned i = 0; i < kCapacity; ++i) rays_[i] = make_ray(dvec3(0.0), dvec3(0.0), 0.0f), rays_[i].id = i;
    std::fill(std::begin(target_), std::end(target_), -1);
    std::fill(std::begin(partner_), std::end(partner_), -1);
  }
  OcclusionBatch(const Visibility& vis, dvec3* front, dvec3* back, const ChangedRays& changed)
      : OcclusionBatch(vis, front, back) {
    changed_ = &changed;
  }
  ~OcclusionBatch() { flush(); }
  OcclusionBatch(const OcclusionBatch&) = delete;  // coincident_rays_ points into it
  OcclusionBatch& operator=(const OcclusionBatch&) = delete;

  // Segment from the receiver to the target, carrying `irradiance` to the receiver's front or back
  // side; the target is pulled off its own surface along its normal, towards the receiver, by
  // epsilon plus its lift. Forced inline: it runs once per ray, between the form factors; a call
  // would run in the baseline ISA (dispatch.h) and recompute what its caller has already worked out
  // (a cell's offset and both heights).
  __attribute__((always_inline)) void to_point(const RayStart& from, const RayEnd& to, bool front,
                                               const dvec3& irradiance) {
    if (to.under_patch >= 0) return through(from, to, front, irradiance);
    dvec3 origin, dir;
    segment_ends(from.x, from.n, to.y, to.normal, vis_.epsilon(), to.lift, origin, dir);
    segment(from.receiver, origin, dir, front, irradiance);
  }
  // The same, for a segment whose ends segment_ends worked out (gather does so four at a time).
  __attribute__((always_inline)) void segment(int receiver, const dvec3& origin, const dvec3& dir, bool front,
                                              const dvec3& irradiance) {
    if (!open(front)) return;
    double eps = vis_.epsilon();
    if (glm::dot(dir, dir) <= 4 * eps * eps) {  // touching: nothing fits (nor moves) in between
      if (!changed_) sum(receiver, front) += share_[!front] * irradiance;
      return;
    }
    push(&sum(receiver, front), origin, dir, kSegment, share_[!front] * irradiance);
  }
  // Light that reaches the receiver without a ray (CornerView::own), not scaled by the share.
  void add(int receiver, bool front, const dvec3& irradiance) {
    if (!changed_) sum(receiver, front) += irradiance;
  }
  // The part of what is sent from now on that the receivers take, per side (ReceiverPoint::reflected_share).
  void set_share(const std::array<double, 2>& share) { share_ = share; }
  // Whether the receivers' front / back sides take what is sent from now on (gather.cpp).
  void set_open(const std::array<bool, 2>& open) { open_ = open; }
  bool open(bool front) const { return open_[!front]; }
  // Ray from x to infinity along dir (sun, sky).
  void to_infinity(int receiver, const dvec3& x, const dvec3& n, const dvec3& dir, bool front,
                   const dvec3& irradiance);
  // Rays pushed from now on aim at images in `mirror` (null: none), whose receivers lie on `side` of
  // it (+1 its normal's): each goes from the receiver to where it crosses the mirror's outline, and
  // on from there to the real point (or along the reflected direction), and carries the light
  // times the mirror's colour. Rays that miss the outline carry nothing. With ChangedRays, a path
  // counts if what the moved objects pass of its two legs together changed.
  void set_mirror(const MirrorPlane* mirror, double side) { mirror_ = mirror, mirror_side_ = side; }
  void flush();
  const Visibility& visibility() const { return vis_; }
  long long rays_traced() const { return traced_; }
  long long rays_pushed() const { return pushed_; }
  const Crossings* crossings() const { return crossings_.get(); }  // null while no ray could cross a pane
  long long mirror_rays() const { return mirror_rays_; }  // legs of paths by way of a mirror pushed

 private:
  // A segment is pushed with tfar = kSegment; flush() shortens it to stop epsilon before its end.
  static constexpr float kSegment = 1.0f;
  // A segment traced through its end's plane (Coincident) is not shortened.
  static constexpr float kThrough = 0.99999994f;

  void through(const RayStart& from, const RayEnd& to, bool front, const dvec3& irradiance);

  dvec3& sum(int receiver, bool front) { return (front ? front_ : back_)[receiver - first_]; }
  __attribute__((always_inline)) void push(dvec3* into, const dvec3& origin, const dvec3& dir, float tfar, const dvec3& irradiance,
                                           int under_patch = -1, float zone_start = 0.0f) {
    if (mirror_) return push_mirrored(into, origin, dir, tfar, irradiance);
    ++pushed_;
    if (changed_ && !changed_->may_have_changed(origin, dir, tfar)) return;
    append(into, origin, dir, tfar, irradiance, under_patch, zone_start);
  }
  // push() without the count or the question whether the ray may have changed.
  __attribute__((always_inline)) void append(dvec3* into, const dvec3& origin, const dvec3& dir, float tfar,
                                             const dvec3& irradiance, int under_patch = -1, float zone_start = 0.0f) {
    if (under_patch >= 0) {
      target_[count_] = vis_.object_of_patch(under_patch);
      target_patch_[count_] = vis_.lies_on_own(under_patch) ? under_patch : -1;
      zone_start_[count_] = zone_start, coincident_ = true;
    }
    aim(rays_[count_], origin, dir, tfar);
    into_[count_] = into;
    carried_[count_] = irradiance;
    if (++count_ == kCapacity) flush();
  }
  // push() while a mirror is set: the two legs, the second linked to the first by partner_; with
  // ChangedRays, both or neither, as either may have changed.
  void push_mirrored(dvec3* into, const dvec3& origin, const dvec3& dir, float tfar, const dvec3& irradiance);
  const Coincident* coincident() const { return coincident_ ? &coincident_rays_ : nullptr; }

  static constexpr unsigned kCapacity = 256;
  static_assert(kCapacity <= ChangedRays::kMaxRays);
  const Visibility& vis_;
  dvec3* front_;
  dvec3* back_;
  const ChangedRays* changed_ = nullptr;
  int first_ = 0;
  std::array<double, 2> share_{1.0, 1.0};
  std::array<bool, 2> open_{true, true};
  RTCRay rays_[kCapacity];
  dvec3* into_[kCapacity];  // the accumulator (receiver and side) each ray adds to
  dvec3 carried_[kCapacity];
  // Per slot (ray id): Coincident's data; -1 at rest, set by push for the few rays that need it.
  int target_[kCapacity];
  int target_patch_[kCapacity];
  float zone_start_[kCapacity];
  bool coincident_ = false;  // some ray of the batch has them
  // Per slot: the second leg of a path by way of a mirror (whose own slot adds nothing), or -1.
  int partner_[kCapacity];
  bool paired_ = false;  // some ray of the batch has one
  const MirrorPlane* mirror_ = nullptr;
  double mirror_side_ = 1.0;
  std::unique_ptr<Crossings> crossings_;  // made on the first flush that needs it
  const Coincident coincident_rays_{target_, target_patch_, zone_start_};
  unsigned count_ = 0;
  long long traced_ = 0;
  long long mirror_rays_ = 0;
  long long pushed_ = 0;
};

}  // namespace radiosity
