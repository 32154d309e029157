#include "changed_rays.h"

#include <cmath>

namespace radiosity {

namespace {

constexpr int kNone = -1, kSeveral = -2;  // which moved objects' zones a ray passes through

}  // namespace

unsigned ChangedRays::keep_changed(RTCRay* rays, dvec3** into, dvec3* carried, const int* partner, unsigned count,
                                  const Coincident* coincident, long long& traced) const {
  // What the moved objects pass of each ray, before and after: 0 where one blocks it, else what
  // the panes it crosses of theirs let through (1 without panes). A ray an object's sphere of one
  // place does not reach, the object there cannot block: each ray is traced against the places it
  // passes near, and no more once one of them blocks it there.
  thread_local Crossings crossings(kMaxRays);
  Crossings* through_panes = panes_ ? &crossings : nullptr;
  dvec3 passed[2][kMaxRays];
  int through[kMaxRays];
  dvec3 origin[kMaxRays], dir[kMaxRays];
  for (unsigned i = 0; i < count; ++i) {
    const RTCRay& r = rays[i];
    through[i] = kNone;
    passed[0][i] = passed[1][i] = dvec3(1.0);
    origin[i] = dvec3(r.org_x, r.org_y, r.org_z), dir[i] = dvec3(r.dir_x, r.dir_y, r.dir_z);
  }
  double eps = vis_.epsilon();
  for (int m = 0; m < int(objects_.size()); ++m) {
    const Zone& zone = zones_[m];
    RTCRay near[2][kMaxRays];
    unsigned which[2][kMaxRays], crossing[2] = {0, 0};
    for (unsigned i = 0; i < count; ++i) {
      if (!ray_crosses(origin[i], dir[i], rays[i].tfar, zone.around)) continue;
      for (int place = 0; place < 2; ++place) {
        if (!ray_crosses(origin[i], dir[i], rays[i].tfar, place == 0 ? zone.before : zone.after)) continue;
        through[i] = through[i] == kNone || through[i] == m ? m : kSeveral;
        if (passed[place][i] != dvec3(0.0)) near[place][crossing[place]] = rays[i], which[place][crossing[place]++] = i;
      }
    }
    for (int place = 0; place < 2; ++place) {
      vis_.occluded_by(objects_[m], place == 0, near[place], crossing[place], coincident, through_panes);
      for (unsigned k = 0; k < crossing[place]; ++k) {
        dvec3& p = passed[place][which[place][k]];
        if (near[place][k].tfar < 0)
          p = dvec3(0.0);
        else if (through_panes)
          p *= crossings.through(near[place][k], eps);
      }
      traced += crossing[place];
    }
  }
  // A path's second leg goes where its first does, after it; `second` marks where it went.
  bool second[kMaxRays];
  unsigned kept = 0;
  auto keep = [&](unsigned i, const dvec3& irradiance, bool is_second) {
    rays[kept] = rays[i];
    into[kept] = into[i];
    carried[kept] = irradiance;
    through[kept] = through[i];
    second[kept++] = is_second;
  };
  for (unsigned i = 0; i < count; ++i) {
    if (!into[i]) continue;  // a second leg
    int j = partner ? partner[i] : -1;
    dvec3 before = passed[0][i], after = passed[1][i];
    if (j >= 0) before *= passed[0][j], after *= passed[1][j];
    if (before == after) continue;
    keep(i, (after - before) * carried[i], false);
    if (j >= 0) keep(unsigned(j), dvec3(0.0), true);
  }
  // What the rest passes of a second leg goes to its first; a blocked one blocks it.
  auto join_legs = [&] {
    if (!partner) return;
    for (unsigned i = 1; i < kept; ++i) {
      if (!second[i]) continue;
      if (rays[i].tfar < 0) rays[i - 1].tfar = -INFINITY;
      else if (through_panes) carried[i - 1] *= crossings.through(rays[i], eps);
    }
  };
  // What else blocks a changed ray: the scene without the moved objects it passes near (those it
  // passes far from block it neither way). Near one, the dB cache of that one knows; near several,
  // it is traced without all of them. Through panes, it is traced without all of them, each time.
  if (through_panes) {
    traced += db_.trace_without(vis_, objects_, rays, kept, coincident, through_panes);
    for (unsigned i = 0; i < kept; ++i)
      if (!second[i] && rays[i].tfar >= 0) carried[i] *= crossings.through(rays[i], eps);
    join_legs();
    return kept;
  }
  for (int m = kSeveral; m < int(objects_.size()); ++m) {
    if (m == kNone) continue;
    RTCRay asked[kMaxRays];
    unsigned which[kMaxRays], n = 0;
    // A leg of a path that passes near none (its other leg does) is traced without them all.
    for (unsigned i = 0; i < kept; ++i)
      if (through[i] == m || (m == kSeveral && through[i] == kNone)) asked[n] = rays[i], which[n++] = i;
    if (n == 0) continue;
    traced += m == kSeveral ? db_.trace_without(vis_, objects_, asked, n, coincident)
                            : db_.trace_without(vis_, objects_[m], asked, n, coincident);
    for (unsigned k = 0; k < n; ++k) rays[which[k]].tfar = asked[k].tfar;
  }
  join_legs();
  return kept;
}

}  // namespace radiosity
