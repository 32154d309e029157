#include "changed_rays.h"

namespace radiosity {

unsigned ChangedRays::keep_changed(RTCRay* rays, dvec3** into, dvec3* carried, unsigned count,
                                  const Coincident* coincident, long long& traced) const {
  // A ray the object's sphere of one place does not reach, the object there cannot block: each ray
  // is traced against the places it passes near, not against both.
  bool blocked[2][kMaxRays];
  for (int place = 0; place < 2; ++place) {
    const Sphere& bounds = place == 0 ? zone_.before : zone_.after;
    RTCRay near[kMaxRays];
    unsigned which[kMaxRays], crossing = 0;
    for (unsigned i = 0; i < count; ++i) {
      const RTCRay& r = rays[i];
      blocked[place][i] = false;
      if (ray_crosses(dvec3(r.org_x, r.org_y, r.org_z), dvec3(r.dir_x, r.dir_y, r.dir_z), r.tfar, bounds))
        near[crossing] = r, which[crossing++] = i;
    }
    vis_.occluded_by(object_, place == 0, near, crossing, coincident);
    for (unsigned k = 0; k < crossing; ++k) blocked[place][which[k]] = near[k].tfar < 0;
    traced += crossing;
  }
  unsigned kept = 0;
  for (unsigned i = 0; i < count; ++i) {
    if (blocked[0][i] == blocked[1][i]) continue;
    double sign = blocked[0][i] ? 1.0 : -1.0;
    rays[kept] = rays[i];
    into[kept] = into[i];
    carried[kept] = sign * carried[i];
    ++kept;
  }
  traced += db_.trace_without(vis_, object_, rays, kept, coincident);
  return kept;
}

}  // namespace radiosity
