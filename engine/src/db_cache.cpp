#include "db_cache.h"

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

DbCache::Origin DbCache::origin_of(const RTCRay& ray) {
  Origin o;
  std::memcpy(o.data(), &ray.org_x, sizeof o);
  return o;
}

DbCache::Rest DbCache::rest_of(const RTCRay& ray) {
  Rest r;
  std::memcpy(r.data(), &ray.dir_x, 3 * sizeof(float));
  std::memcpy(&r[3], &ray.tfar, sizeof(float));
  return r;
}

std::size_t DbCache::kept_bytes(std::size_t entries, std::size_t origins) const {
  return entries * sizeof(Known) + origins * (sizeof(Origin) + sizeof(std::vector<Known>) + kAllocation);
}

void DbCache::forget() {
  std::vector<Origin>().swap(origins_);
  std::vector<std::vector<Known>>().swap(known_);
  entries_ = 0;
}

void DbCache::own(int object) {
  if (owner_ == object) return;
  owner_ = object;
  forget();
}

void DbCache::find(const RTCRay* rays, unsigned count, Answer* answers) const {
  const std::vector<Known>* bucket = nullptr;
  Origin last{};
  bool looked = false;
  for (unsigned i = 0; i < count; ++i) {
    answers[i] = unknown;
    if (entries_ == 0) continue;
    Origin o = origin_of(rays[i]);
    if (!looked || o != last) {  // rays of one receiver come in a row
      looked = true, last = o;
      auto it = std::lower_bound(origins_.begin(), origins_.end(), o);
      bucket = it != origins_.end() && *it == o ? &known_[it - origins_.begin()] : nullptr;
    }
    if (!bucket) continue;
    Rest r = rest_of(rays[i]);
    auto k = std::lower_bound(bucket->begin(), bucket->end(), r, [](const Known& a, const Rest& b) { return a.rest < b; });
    if (k != bucket->end() && k->rest == r) answers[i] = Answer(k->answer);
  }
}

void DbCache::stage(const RTCRay* rays, const unsigned* which, const RTCRay* traced, unsigned count, unsigned hits) {
  std::lock_guard<std::mutex> lock(mutex_);
  counts_.hits += hits;
  counts_.misses += count;
  std::size_t limit = cap_ / 4 / sizeof(Staged);  // a quarter of the cap
  count = unsigned(std::min<std::size_t>(count, limit - std::min(limit, staged_.size())));
  if (staged_.size() + count > staged_.capacity())  // grown by hand: doubling must not pass the cap
    staged_.reserve(std::min(limit, std::max<std::size_t>(2 * staged_.capacity(), staged_.size() + count)));
  for (unsigned k = 0; k < count; ++k) {
    const RTCRay& r = rays[which[k]];
    staged_.push_back({origin_of(r), {rest_of(r), traced[k].tfar < 0 ? blocked : clear}});
  }
}

void DbCache::commit() {
  if (staged_.empty()) return;
  // A receiver's rays come in a row: runs of one origin. Sorted by run, then each origin's answers
  // apart: a sort of all of them at once would cost a drag (every update new answers) what it spares.
  std::vector<std::size_t> runs;
  for (std::size_t k = 0; k < staged_.size(); ++k)
    if (k == 0 || staged_[k].origin != staged_[k - 1].origin) runs.push_back(k);
  runs.push_back(staged_.size());
  std::vector<Origin> fresh;
  for (std::size_t r = 0; r + 1 < runs.size(); ++r) fresh.push_back(staged_[runs[r]].origin);
  std::sort(fresh.begin(), fresh.end());
  fresh.erase(std::unique(fresh.begin(), fresh.end()), fresh.end());
  // What is kept has three quarters of the cap; full, it starts over with these (at most a quarter
  // of the cap staged, 32 bytes an answer: kept, 72 at most).
  if (kept_bytes(entries_ + staged_.size(), origins_.size() + fresh.size()) > cap_ / 4 * 3) forget();

  // Every origin, each with its answers so far (none, if fresh).
  std::vector<Origin> origins;
  std::vector<std::vector<Known>> known;
  origins.reserve(origins_.size() + fresh.size());
  known.reserve(origins_.size() + fresh.size());
  for (std::size_t i = 0, f = 0; i < origins_.size() || f < fresh.size();) {
    bool old = i < origins_.size() && (f == fresh.size() || !(fresh[f] < origins_[i]));
    if (old && f < fresh.size() && fresh[f] == origins_[i]) ++f;
    origins.push_back(old ? origins_[i] : fresh[f++]);
    known.push_back(old ? std::move(known_[i++]) : std::vector<Known>());
  }
  origins_ = std::move(origins);
  known_ = std::move(known);

  // The new answers by origin (a counting sort), then each origin's in order, merged in.
  std::vector<std::size_t> start(origins_.size() + 1, 0);
  std::vector<uint32_t> to(runs.size() - 1);
  for (std::size_t r = 0; r + 1 < runs.size(); ++r) {
    to[r] = uint32_t(std::lower_bound(origins_.begin(), origins_.end(), staged_[runs[r]].origin) - origins_.begin());
    start[to[r] + 1] += runs[r + 1] - runs[r];
  }
  for (std::size_t b = 0; b < origins_.size(); ++b) start[b + 1] += start[b];
  std::vector<Known> grouped(staged_.size());
  std::vector<std::size_t> next(start.begin(), start.end() - 1);
  for (std::size_t r = 0; r + 1 < runs.size(); ++r)
    for (std::size_t k = runs[r]; k < runs[r + 1]; ++k) grouped[next[to[r]]++] = staged_[k].known;
  std::vector<Staged>().swap(staged_);
  auto before = [](const Known& a, const Known& b) { return a.rest < b.rest; };
  for (std::size_t b = 0; b < origins_.size(); ++b) {
    if (start[b] == start[b + 1]) continue;
    auto first = grouped.begin() + start[b], last = grouped.begin() + start[b + 1];
    std::sort(first, last, before);
    std::vector<Known>& old = known_[b];
    std::vector<Known> merged;
    merged.reserve(old.size() + (last - first));
    std::merge(old.begin(), old.end(), first, last, std::back_inserter(merged), before);
    // A ray asked twice in one gather (by two threads) is staged twice, with one answer.
    merged.erase(std::unique(merged.begin(), merged.end(), [](const Known& a, const Known& b) { return a.rest == b.rest; }),
                 merged.end());
    entries_ += merged.size() - old.size();
    old = std::move(merged);
  }
}

DbCache::Counts DbCache::take_counts() {
  Counts c = counts_;
  counts_ = Counts();
  return c;
}

std::size_t DbCache::bytes() const {
  std::size_t b = origins_.capacity() * sizeof(Origin) + known_.capacity() * sizeof(std::vector<Known>) +
                  staged_.capacity() * sizeof(Staged);
  for (const std::vector<Known>& k : known_) b += k.capacity() * sizeof(Known) + (k.capacity() ? kAllocation : 0);
  return b;
}

unsigned DbCache::trace_without(const Visibility& vis, int object, RTCRay* rays, unsigned count,
                                const Coincident* coincident) {
  Answer known[kMaxRays];
  find(rays, count, known);
  RTCRay missed[kMaxRays];
  unsigned where[kMaxRays], misses = 0;
  for (unsigned i = 0; i < count; ++i) switch (known[i]) {
      case unknown: missed[misses] = rays[i], where[misses++] = i; break;
      case blocked: rays[i].tfar = -INFINITY; break;
      case clear: break;
    }
  vis.occluded_without(object, missed, misses, coincident);
  if (count > 0) stage(rays, where, missed, misses, count - misses);
  for (unsigned k = 0; k < misses; ++k) rays[where[k]].tfar = missed[k].tfar;
  return misses;
}

}  // namespace radiosity
