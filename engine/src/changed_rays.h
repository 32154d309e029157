// What one object's last move changed of a gather's rays: the paper's exit and enter zones (sec. 4).
//
// A ray counts with + if the object blocked it before and not now (the exit zone), - if the reverse
// (the enter zone), and only if nothing else blocks it. A ray the object blocks both times, or
// neither, costs no trace of the whole scene, and one that passes through neither of the object's
// bounding spheres (`zone`) no trace at all. What else blocks a changed ray comes from the dB cache
// when it knows, else from a trace that it keeps there.
#pragma once

#include "bounds.h"
#include "db_cache.h"
#include "visibility.h"

namespace radiosity {

class ChangedRays {
 public:
  static constexpr unsigned kMaxRays = DbCache::kMaxRays;  // at once

  // Shared by the threads of a gather: `db` takes what they trace from all of them.
  ChangedRays(const Visibility& vis, int object, const Zone& zone, DbCache& db)
      : vis_(vis), object_(object), zone_(zone), db_(db) {}

  // Whether the move may have changed the ray: it passes through a place of the object.
  bool may_have_changed(const dvec3& origin, const dvec3& dir, double t_max) const {
    return zone_.crossed_by(origin, dir, t_max);
  }

  // Of `count` rays, each carrying carried[i] into *into[i], moves to the front (in their order) the
  // ones the move changed, their irradiance signed, and traces those against the rest of the scene:
  // the ones that come back with tfar >= 0 count. Returns how many it moved; adds the rays it
  // traced to `traced`.
  unsigned keep_changed(RTCRay* rays, dvec3** into, dvec3* carried, unsigned count, const Coincident* coincident,
                        long long& traced) const;

 private:
  const Visibility& vis_;
  int object_;
  const Zone& zone_;
  DbCache& db_;
};

}  // namespace radiosity
