#include "db_cache.h"

#include "parallel.h"
#include "visibility.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iterator>

namespace radiosity {

namespace {

constexpr std::size_t kAllocation = 16;  // the allocator's own, per bucket

}  // namespace

DbCache::DbCache(double megabytes) {
  if (megabytes > 0) cap_ = std::size_t(megabytes * 1024 * 1024);  // NaN or negative: no cache
}

std::size_t DbCache::kept_bytes(std::size_t entries, std::size_t origins) const {
  return entries * sizeof(Known) + origins * (sizeof(Origin) + sizeof(std::vector<Known>) + kAllocation);
}

std::size_t DbCache::kept_bytes() const {
  std::size_t b = 0;
  for (const auto& [object, t] : tables_) b += kept_bytes(t.entries, t.origins.size());
  return b;
}

std::size_t DbCache::entries() const {
  std::size_t n = 0;
  for (const auto& [object, t] : tables_) n += t.entries;
  return n;
}

void DbCache::moved(int object, const Zone& zone) {
  if (cap_ == 0) return;
  tables_[object].moved = ++clock_;
  for (auto& [other, t] : tables_) {
    if (other == object || t.entries == 0) continue;
    t.stale.push_back(zone);
    if (t.stale.size() > kMaxStale) forget_stale(t);
  }
}

void DbCache::prepare(int object) {
  auto table = tables_.find(object);
  if (table != tables_.end()) forget_stale(table->second);
}

void DbCache::forget_stale(Table& t) {
  if (t.stale.empty()) return;
  // Per origin, in parallel: a table holds a million answers or more.
  std::vector<std::size_t> left(t.origins.size());
  parallel_for(0, int(t.origins.size()), 64, [&](int b) {
    float o[3];
    std::memcpy(o, t.origins[b].data(), sizeof o);
    dvec3 origin(o[0], o[1], o[2]);
    std::vector<Known>& known = t.known[b];
    std::size_t was = known.size();
    known.erase(std::remove_if(known.begin(), known.end(),
                               [&](const Known& k) {
                                 float r[4];
                                 std::memcpy(r, k.rest.data(), sizeof r);
                                 dvec3 dir(r[0], r[1], r[2]);
                                 for (const Zone& zone : t.stale)
                                   if (zone.crossed_by(origin, dir, r[3])) return true;
                                 return false;
                               }),
                known.end());
    if (known.size() < was) known.shrink_to_fit();  // bytes() counts what is held
    left[b] = known.size();
  });
  std::vector<Zone>().swap(t.stale);
  std::size_t kept = 0, entries = 0;
  for (std::size_t b = 0; b < t.origins.size(); ++b) {
    if (left[b] == 0) {
      std::vector<Known>().swap(t.known[b]);
      continue;
    }
    if (kept < b) t.origins[kept] = t.origins[b], t.known[kept] = std::move(t.known[b]);
    ++kept;
    entries += left[b];
  }
  t.origins.resize(kept), t.origins.shrink_to_fit();
  t.known.resize(kept), t.known.shrink_to_fit();
  t.entries = entries;
}

void DbCache::find(int object, const RTCRay* rays, unsigned count, Answer* answers) const {
  std::fill(answers, answers + count, unknown);
  auto table = tables_.find(object);
  // Not prepared since another object moved: nothing it holds can be trusted.
  if (table == tables_.end() || table->second.entries == 0 || !table->second.stale.empty()) return;
  const Table& t = table->second;
  const std::vector<Known>* bucket = nullptr;
  Origin last{};
  bool looked = false;
  for (unsigned i = 0; i < count; ++i) {
    Origin o = origin_of(rays[i]);
    if (!looked || o != last) {  // rays of one receiver come in a row
      looked = true, last = o;
      auto it = std::lower_bound(t.origins.begin(), t.origins.end(), o);
      bucket = it != t.origins.end() && *it == o ? &t.known[it - t.origins.begin()] : nullptr;
    }
    if (!bucket) continue;
    Rest r = rest_of(rays[i]);
    auto k = std::lower_bound(bucket->begin(), bucket->end(), r, [](const Known& a, const Rest& b) { return a.rest < b; });
    if (k != bucket->end() && k->rest == r) answers[i] = Answer(k->answer);
  }
}

void DbCache::stage(int object, const RTCRay* rays, const unsigned* which, const RTCRay* traced, unsigned count,
                    unsigned hits) {
  std::lock_guard<std::mutex> lock(mutex_);
  counts_.hits += hits;
  counts_.misses += count;
  std::vector<Staged>& staged = staged_[object];
  // A quarter of the cap, for all objects: this one's room is what the others have not reserved.
  std::size_t limit = cap_ / 4 / sizeof(Staged);
  std::size_t room = limit - std::min(limit, staged_reserved_ - staged.capacity());
  count = unsigned(std::min<std::size_t>(count, room - std::min(room, staged.size())));
  if (staged.size() + count > staged.capacity()) {  // grown by hand: doubling must not pass the cap
    std::size_t was = staged.capacity();
    staged.reserve(std::min(room, std::max<std::size_t>(2 * was, staged.size() + count)));
    staged_reserved_ += staged.capacity() - was;
  }
  for (unsigned k = 0; k < count; ++k) {
    const RTCRay& r = rays[which[k]];
    staged.push_back({origin_of(r), {rest_of(r), traced[k].tfar < 0 ? blocked : clear}});
  }
}

void DbCache::make_room(int keep, std::size_t more, std::size_t more_origins) {
  std::size_t room = cap_ / 4 * 3;
  if (kept_bytes() + kept_bytes(more, more_origins) > room)  // what other moves made wrong goes first
    for (auto& [object, t] : tables_) forget_stale(t);
  while (kept_bytes() + kept_bytes(more, more_origins) > room) {
    auto oldest = tables_.end();
    for (auto it = tables_.begin(); it != tables_.end(); ++it)
      if (it->first != keep && it->second.entries > 0 &&
          (oldest == tables_.end() || it->second.moved < oldest->second.moved))
        oldest = it;
    if (oldest == tables_.end()) break;
    oldest->second = Table{{}, {}, 0, oldest->second.moved, {}};
  }
  if (kept_bytes() + kept_bytes(more, more_origins) > room) {
    Table& own = tables_[keep];
    own = Table{{}, {}, 0, own.moved, {}};
  }
}

void DbCache::commit() {
  for (auto& [object, staged] : staged_) commit(object, staged);
  staged_.clear();
  staged_reserved_ = 0;
}

void DbCache::commit(int object, std::vector<Staged>& staged) {
  if (staged.empty()) return;
  // A receiver's rays come in a row: runs of one origin. Sorted by run, then each origin's answers
  // apart: a sort of all of them at once would cost a drag (every update new answers) what it spares.
  std::vector<std::size_t> runs;
  for (std::size_t k = 0; k < staged.size(); ++k)
    if (k == 0 || staged[k].origin != staged[k - 1].origin) runs.push_back(k);
  runs.push_back(staged.size());
  std::vector<Origin> fresh;
  for (std::size_t r = 0; r + 1 < runs.size(); ++r) fresh.push_back(staged[runs[r]].origin);
  std::sort(fresh.begin(), fresh.end());
  fresh.erase(std::unique(fresh.begin(), fresh.end()), fresh.end());
  // What is kept has three quarters of the cap (at most a quarter of the cap staged, 32 bytes an
  // answer: kept, 72 at most).
  make_room(object, staged.size(), fresh.size());
  Table& t = tables_[object];
  forget_stale(t);  // prepared before the gather, unless the gather asked nothing

  // Every origin, each with its answers so far (none, if fresh).
  std::vector<Origin> origins;
  std::vector<std::vector<Known>> known;
  origins.reserve(t.origins.size() + fresh.size());
  known.reserve(t.origins.size() + fresh.size());
  for (std::size_t i = 0, f = 0; i < t.origins.size() || f < fresh.size();) {
    bool old = i < t.origins.size() && (f == fresh.size() || !(fresh[f] < t.origins[i]));
    if (old && f < fresh.size() && fresh[f] == t.origins[i]) ++f;
    origins.push_back(old ? t.origins[i] : fresh[f++]);
    known.push_back(old ? std::move(t.known[i++]) : std::vector<Known>());
  }
  t.origins = std::move(origins);
  t.known = std::move(known);

  // The new answers by origin (a counting sort), then each origin's in order, merged in.
  std::vector<std::size_t> start(t.origins.size() + 1, 0);
  std::vector<uint32_t> to(runs.size() - 1);
  for (std::size_t r = 0; r + 1 < runs.size(); ++r) {
    to[r] = uint32_t(std::lower_bound(t.origins.begin(), t.origins.end(), staged[runs[r]].origin) - t.origins.begin());
    start[to[r] + 1] += runs[r + 1] - runs[r];
  }
  for (std::size_t b = 0; b < t.origins.size(); ++b) start[b + 1] += start[b];
  std::vector<Known> grouped(staged.size());
  std::vector<std::size_t> next(start.begin(), start.end() - 1);
  for (std::size_t r = 0; r + 1 < runs.size(); ++r)
    for (std::size_t k = runs[r]; k < runs[r + 1]; ++k) grouped[next[to[r]]++] = staged[k].known;
  std::vector<Staged>().swap(staged);
  auto before = [](const Known& a, const Known& b) { return a.rest < b.rest; };
  for (std::size_t b = 0; b < t.origins.size(); ++b) {
    if (start[b] == start[b + 1]) continue;
    auto first = grouped.begin() + start[b], last = grouped.begin() + start[b + 1];
    std::sort(first, last, before);
    std::vector<Known>& old = t.known[b];
    std::vector<Known> merged;
    merged.reserve(old.size() + (last - first));
    std::merge(old.begin(), old.end(), first, last, std::back_inserter(merged), before);
    // A ray asked twice in one gather (by two threads) is staged twice, with one answer.
    merged.erase(std::unique(merged.begin(), merged.end(), [](const Known& a, const Known& b) { return a.rest == b.rest; }),
                 merged.end());
    t.entries += merged.size() - old.size();
    old = std::move(merged);
  }
}

DbCache::Counts DbCache::take_counts() {
  Counts c = counts_;
  counts_ = Counts();
  return c;
}

std::size_t DbCache::bytes() const {
  std::size_t b = 0;
  for (const auto& [object, staged] : staged_) b += staged.capacity() * sizeof(Staged);
  for (const auto& [object, t] : tables_) {
    b += t.origins.capacity() * sizeof(Origin) + t.known.capacity() * sizeof(std::vector<Known>);
    for (const std::vector<Known>& k : t.known) b += k.capacity() * sizeof(Known) + (k.capacity() ? kAllocation : 0);
  }
  return b;
}

unsigned DbCache::trace_without(const Visibility& vis, int object, RTCRay* rays, unsigned count,
                                const Coincident* coincident) {
  Answer known[kMaxRays];
  find(object, rays, count, known);
  RTCRay missed[kMaxRays];
  unsigned where[kMaxRays], misses = 0;
  for (unsigned i = 0; i < count; ++i) switch (known[i]) {
      case unknown: missed[misses] = rays[i], where[misses++] = i; break;
      case blocked: rays[i].tfar = -INFINITY; break;
      case clear: break;
    }
  vis.occluded_without(object, missed, misses, coincident);
  if (count > 0) stage(object, rays, where, missed, misses, count - misses);
  for (unsigned k = 0; k < misses; ++k) rays[where[k]].tfar = missed[k].tfar;
  return misses;
}

unsigned DbCache::trace_without(const Visibility& vis, const std::vector<int>& objects, RTCRay* rays,
                                unsigned count, const Coincident* coincident, Crossings* crossings) {
  vis.occluded_without(objects, rays, count, coincident, crossings);
  std::lock_guard<std::mutex> lock(mutex_);
  counts_.misses += count;
  return count;
}

}  // namespace radiosity
