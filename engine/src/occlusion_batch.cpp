#include "occlusion_batch.h"

#include "dispatch.h"
#include "mirror.h"

#include <cmath>

#include <smmintrin.h>

namespace radiosity {

void OcclusionBatch::to_infinity(int receiver, const dvec3& x, const dvec3& n, const dvec3& dir, bool front,
                                 const dvec3& irradiance) {
  double eps = vis_.epsilon();
  push(&sum(receiver, front), x + (glm::dot(n, dir) >= 0 ? eps : -eps) * n, dir, INFINITY, share_[!front] * irradiance);
}

void OcclusionBatch::through(const RayStart& from, const RayEnd& to, bool front, const dvec3& irradiance) {
  if (!open(front)) return;
  double eps = vis_.epsilon();
  const dvec3& y = to.y;
  dvec3 origin, dir;
  segment_ends(from.x, from.n, y, to.normal, eps, to.lift, origin, dir);
  if (glm::dot(dir, dir) <= 4 * eps * eps) return segment(from.receiver, origin, dir, front, irradiance);
  // As far past y as an ordinary segment ends short of it; the zone starts where that one stops.
  dvec3 short_end = origin + dir;
  dvec3 past = 2.0 * y - short_end - origin;
  double length = glm::length(past);
  double zone = (glm::dot(dir, past) / length - eps) / length;
  push(&sum(from.receiver, front), origin, past, kThrough, share_[!front] * irradiance, to.under_patch, float(zone));
}

void OcclusionBatch::push_mirrored(dvec3* into, const dvec3& origin, const dvec3& dir, float tfar,
                                   const dvec3& irradiance) {
  const MirrorPlane& mirror = *mirror_;
  bool infinite = std::isinf(tfar);
  double t = mirror.crossing(origin, dir, infinite ? INFINITY : 1.0);
  if (!(t > 0)) return;
  dvec3 p = origin + t * dir;
  // The second leg leaves the mirror lifted off it towards the receiver's side, for the real end
  // (the image end reflected back: lifted off its surface as the image end was) or to infinity.
  dvec3 start = p + (mirror_side_ * vis_.epsilon()) * mirror.normal();
  dvec3 onward = infinite ? mirror.reflect_direction(dir) : mirror.reflect(origin + dir) - start;
  float onward_far = infinite ? INFINITY : kSegment;
  pushed_ += 2;
  if (changed_ && !changed_->may_have_changed(origin, t * dir, kSegment) &&
      !changed_->may_have_changed(start, onward, onward_far))
    return;
  if (count_ + 2 > kCapacity) flush();  // both legs in one stream
  partner_[count_] = int(count_) + 1;
  paired_ = true;
  append(into, origin, t * dir, kSegment, irradiance * mirror.reflectance());
  append(nullptr, start, onward, onward_far, dvec3(0.0));
  mirror_rays_ += 2;
}

RADIOSITY_HOT void OcclusionBatch::flush() {
  if (count_ == 0) return;
  // Each segment stops epsilon short of its end. Worked out here for the whole batch, where the
  // square roots and divisions of different rays overlap rather than wait on each other between
  // form factors; four rays at a time (SSE, in the baseline ISA too), so that the loop does not
  // wait on the divider. The same operations in the same order as one at a time, so the same bits.
  float eps = float(vis_.epsilon());
  auto shorten = [&](RTCRay& r) {
    if (r.tfar == kSegment) r.tfar = 1.0f - eps / std::sqrt(r.dir_x * r.dir_x + r.dir_y * r.dir_y + r.dir_z * r.dir_z);
  };
  const __m128 one = _mm_set1_ps(1.0f), epsilon = _mm_set1_ps(eps), segment = _mm_set1_ps(kSegment);
  unsigned i = 0;
  for (; i + 4 <= count_; i += 4) {
    RTCRay* r = rays_ + i;
    __m128 x = _mm_setr_ps(r[0].dir_x, r[1].dir_x, r[2].dir_x, r[3].dir_x);
    __m128 y = _mm_setr_ps(r[0].dir_y, r[1].dir_y, r[2].dir_y, r[3].dir_y);
    __m128 z = _mm_setr_ps(r[0].dir_z, r[1].dir_z, r[2].dir_z, r[3].dir_z);
    __m128 tfar = _mm_setr_ps(r[0].tfar, r[1].tfar, r[2].tfar, r[3].tfar);
    __m128 length = _mm_sqrt_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(x, x), _mm_mul_ps(y, y)), _mm_mul_ps(z, z)));
    __m128 shortened = _mm_sub_ps(one, _mm_div_ps(epsilon, length));
    alignas(16) float out[4];
    _mm_store_ps(out, _mm_blendv_ps(tfar, shortened, _mm_cmpeq_ps(tfar, segment)));
    for (int l = 0; l < 4; ++l) r[l].tfar = out[l];
  }
  for (; i < count_; ++i) shorten(rays_[i]);
  unsigned pushed = count_;
  if (changed_) {
    count_ = changed_->keep_changed(rays_, into_, carried_, paired_ ? partner_ : nullptr, count_, coincident(), traced_);
  } else {
    if (vis_.transmits() && !crossings_) crossings_ = std::make_unique<Crossings>(kCapacity);
    vis_.occluded(rays_, count_, coincident(), crossings_.get());
    traced_ += count_;
  }
  if (changed_) {  // keep_changed took each path's two legs as one, into its first
    for (unsigned i = 0; i < count_; ++i)
      if (into_[i] && rays_[i].tfar >= 0) *into_[i] += carried_[i];
  } else if (paired_) {
    double eps = vis_.epsilon();
    auto through = [&](unsigned i) { return crossings_ ? crossings_->through(rays_[i], eps) : dvec3(1.0); };
    for (unsigned i = 0; i < count_; ++i) {
      if (!into_[i] || rays_[i].tfar < 0) continue;  // a second leg, or blocked
      int j = partner_[i];
      if (j < 0) *into_[i] += carried_[i] * through(i);
      else if (rays_[j].tfar >= 0) *into_[i] += carried_[i] * through(i) * through(j);
    }
  } else if (!crossings_) {
    for (unsigned i = 0; i < count_; ++i)
      if (rays_[i].tfar >= 0) *into_[i] += carried_[i];
  } else {
    double eps = vis_.epsilon();
    for (unsigned i = 0; i < count_; ++i)
      if (rays_[i].tfar >= 0) *into_[i] += carried_[i] * crossings_->through(rays_[i], eps);
  }
  count_ = 0;
  if (paired_) std::fill(partner_, partner_ + pushed, -1), paired_ = false;
  if (changed_)  // keep_changed moved rays to other slots: each gets its slot's id back
    for (unsigned k = 0; k < pushed; ++k) rays_[k].id = k;
  if (coincident_) std::fill(target_, target_ + pushed, -1), coincident_ = false;
}

}  // namespace radiosity
