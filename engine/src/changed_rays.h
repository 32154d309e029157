// What the objects one update moves changed of a gather's rays: the paper's exit and enter zones
// (sec. 4), for all of them at once.
//
// A ray counts with + if some moved object blocked it before and none does now (the exit zone), -
// if the reverse (the enter zone), and only if nothing else blocks it. A ray the moved objects block
// both times, or neither, costs no trace of the whole scene, and one that passes through none of
// their bounding spheres (`zones`) no trace at all. What else blocks a changed ray comes from the
// dB cache when it knows, else from a trace that it keeps there. A ray in several objects' zones
// (overlapping shadows) is asked about once, against all of them.
//
// Where panes let light through (a moved pane, or one standing elsewhere), what the moved objects
// pass of a ray, T, is a colour between 0 (blocked) and 1, and a ray counts with T after - T before
// times what the rest of the scene passes of it: the signs above when every T is 0 or 1. The dB
// cache keeps only clear or blocked, so there the rest is traced each time.
#pragma once

#include "bounds.h"
#include "db_cache.h"
#include "visibility.h"

#include <algorithm>
#include <vector>

namespace radiosity {

class ChangedRays {
 public:
  static constexpr unsigned kMaxRays = DbCache::kMaxRays;  // at once

  // `objects` moved, each between the places of its zones[k]. Shared by the threads of a gather:
  // `db` takes what they trace from all of them.
  ChangedRays(const Visibility& vis, const std::vector<int>& objects, const std::vector<Zone>& zones, DbCache& db)
      : vis_(vis), objects_(objects), zones_(zones), all_{zones.data(), int(zones.size())}, db_(db),
        panes_(vis.transmits() || std::any_of(objects.begin(), objects.end(),
                                              [&](int o) { return vis.has_panes(o, true); })) {}

  // Whether the move may have changed the ray: it passes through a place of a moved object.
  bool may_have_changed(const dvec3& origin, const dvec3& dir, double t_max) const {
    return all_.crossed_by(origin, dir, t_max);
  }

  // Of `count` rays, each carrying carried[i] into *into[i], moves to the front (in their order) the
  // ones the move changed, their irradiance signed (and scaled by what panes pass of it), and traces
  // those against the rest of the scene: the ones that come back with tfar >= 0 and an `into` count.
  // With `partner`, a ray whose partner[i] is not -1 is the first leg of a path by way of a mirror
  // whose second leg (into null) is ray partner[i]: the two count as one ray, what the moved
  // objects and the rest pass of both legs multiplied, into the first. Returns how many it moved;
  // adds the rays it traced to `traced`.
  unsigned keep_changed(RTCRay* rays, dvec3** into, dvec3* carried, const int* partner, unsigned count,
                        const Coincident* coincident, long long& traced) const;

 private:
  const Visibility& vis_;
  const std::vector<int>& objects_;
  const std::vector<Zone>& zones_;
  Zones all_;
  DbCache& db_;
  bool panes_;  // some moved object, before or after, or the rest of the scene lets light through
};

}  // namespace radiosity
