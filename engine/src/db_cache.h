// The dB cache (the paper's per-shooter dB, sec. 4): what the scene without a moved object does to
// the rays whose visibility that object's moves changed.
//
// An update traces each candidate ray against the moved object alone, before and after; a ray the
// move changed then needs a trace of the whole scene without the object (occluded_without) to know
// whether anything else blocks it. That answer depends on the ray and the other objects only: not
// on where the object is, nor on any light. Kept, it serves every later move of the same object
// that changes the same ray: a move back changes the rays the move there did (its exit zone that
// move's enter zone, and the reverse), and a few more: a cell near a receiver asks, with the object
// where it is, which corners of its patch light the part the receiver sees (gather.cpp: exact_cell).
// The next step of a drag asks about few of them: rays that the place it leaves alone blocked, or
// alone did not. The light a ray carries comes from the shooters' current totals and is worked out
// anew, so nothing kept goes stale as shooters shoot on; visibility is all there is to keep.
// Sample positions are deterministic, so a static source and receiver give the same ray, bit for
// bit, each update: the key is its exact bits, compared whole, not a hash of them.
//
// Answers are kept per ray origin (a receiving point's side), sorted: a gather asks about one
// receiver's rays in a row, so a look-up reads memory the one before brought in. In one table by
// hash, every look-up would miss the processor's caches.
//
// Each moved object has answers of its own: several objects moving at once (a frame of an animation)
// each ask about their own rays, frame after frame, in one gather. An answer about the scene
// without one object holds until another object changes where that other can block the ray: its
// place before or after (moved, with its Zone). Only those rays go; the rest stay. They go when the
// object's answers are next asked for (prepare): several objects moving in one update cost one pass
// over each object's answers, not one per mover. A ray that passes by several objects moving
// together needs the scene without all of them; such rays are few, and not kept.
// Memory stays under the cap (what is kept and one update's new answers together); when full, the
// answers other objects' moves made wrong go first, then those of the objects that moved longest
// ago, and if that is not room enough the cache starts over with the latest update's answers, the
// ones the next move most likely asks for.
#pragma once

#include "bounds.h"

#include <embree3/rtcore.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <map>
#include <mutex>
#include <vector>

namespace radiosity {

class Crossings;
class Visibility;
struct Coincident;

class DbCache {
 public:
  enum Answer : uint32_t { unknown = 0, clear = 1, blocked = 2 };
  static constexpr unsigned kMaxRays = 256;  // trace_without's at once

  explicit DbCache(double megabytes);

  // `object` changed between zone.before and zone.after (moved, deformed, appeared or vanished): the
  // answers about the scene without any other object go for the rays it may block in either place.
  // Its own stay: they are about the scene without it.
  void moved(int object, const Zone& zone);
  // Before a gather of `object`'s changed rays: forgets what other objects' moves since made wrong.
  // Until then find() knows nothing of it.
  void prepare(int object);
  // What is known of each ray through the scene without `object`; read-only, so safe from every
  // thread of a gather while others stage().
  void find(int object, const RTCRay* rays, unsigned count, Answer* answers) const;
  // Answers just traced without `object`, from any thread of a gather (of any objects'): ray
  // rays[which[k]] as find() was asked, and traced[k] as it came back; `hits` other rays find()
  // answered. Kept by commit(), once the gather is over.
  void stage(int object, const RTCRay* rays, const unsigned* which, const RTCRay* traced, unsigned count,
             unsigned hits);
  void commit();

  // Traces `count` rays (kMaxRays at most) against the scene without `object`, as
  // Visibility::occluded_without does, through the cache: what it knows it answers, what it does not
  // is traced and staged. Returns the rays it traced. From any thread of a gather.
  unsigned trace_without(const Visibility& vis, int object, RTCRay* rays, unsigned count,
                         const Coincident* coincident);
  // The same without several objects at once, or on through panes (recorded in `crossings`): traced,
  // counted as misses, not kept.
  unsigned trace_without(const Visibility& vis, const std::vector<int>& objects, RTCRay* rays, unsigned count,
                         const Coincident* coincident, Crossings* crossings = nullptr);

  struct Counts {
    long long hits = 0, misses = 0;
  };
  Counts take_counts();  // since the last call
  std::size_t entries() const;  // answers kept, of all objects
  std::size_t bytes() const;    // held now

 private:
  using Origin = std::array<uint32_t, 3>;  // bits
  using Rest = std::array<uint32_t, 4>;    // direction and tfar, bits
  struct Known {
    Rest rest;
    uint32_t answer;
  };
  struct Staged {
    Origin origin;
    Known known;
  };
  // One object's answers, by ray origin.
  struct Table {
    std::vector<Origin> origins;             // sorted
    std::vector<std::vector<Known>> known;   // per origin, sorted by rest
    std::size_t entries = 0;
    long long moved = 0;  // when the object last moved (DbCache::clock_)
    std::vector<Zone> stale;  // other objects' moves since prepare(): what they may block goes
  };
  static constexpr std::size_t kMaxStale = 32;  // moves kept in `stale` before they are applied
  void forget_stale(Table& t);
  // Inline: asked once a ray, on every thread of a gather.
  static Origin origin_of(const RTCRay& ray) {
    Origin o;
    std::memcpy(o.data(), &ray.org_x, sizeof o);
    return o;
  }
  static Rest rest_of(const RTCRay& ray) {
    Rest r;
    std::memcpy(r.data(), &ray.dir_x, 3 * sizeof(float));
    std::memcpy(&r[3], &ray.tfar, sizeof(float));
    return r;
  }
  std::size_t kept_bytes(std::size_t entries, std::size_t origins) const;
  std::size_t kept_bytes() const;  // of all tables
  // Drops what other moves made wrong, then the tables of the objects that moved longest ago, then
  // `keep`'s own, until `more` entries at `more_origins` new origins fit what is kept.
  void make_room(int keep, std::size_t more, std::size_t more_origins);
  void commit(int object, std::vector<Staged>& staged);  // one object's staged answers

  std::size_t cap_ = 0;  // bytes: three quarters for what is kept, a quarter for staging
  std::map<int, Table> tables_;
  long long clock_ = 0;  // moves so far
  std::mutex mutex_;     // guards what stage() writes
  std::map<int, std::vector<Staged>> staged_;  // per object
  std::size_t staged_reserved_ = 0;            // capacity, of all objects
  Counts counts_;
};

}  // namespace radiosity
