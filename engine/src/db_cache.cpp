#include "db_cache.h"

#include <algorithm>
#include <cstring>

namespace radiosity {

namespace {

constexpr std::size_t kFirstSlots = 1024;

}  // namespace

DbCache::DbCache(double megabytes) {
  double bytes = megabytes > 0 ? megabytes * 1024 * 1024 : 0.0;  // NaN or negative: no cache
  // The table at most max_slots_ entries, and staged answers at most half as many (what it can
  // take): 1.5 entries a slot.
  for (std::size_t slots = 2; 1.5 * double(slots * sizeof(Entry)) <= bytes; slots *= 2) max_slots_ = slots;
}

void DbCache::own(int object) {
  if (owner_ == object) return;
  owner_ = object;
  std::vector<Entry>().swap(table_);
  entries_ = 0;
}

DbCache::Entry DbCache::entry(const RTCRay& ray, Answer answer) {
  Entry e;
  std::memcpy(&e.key[0], &ray.org_x, 3 * sizeof(float));
  std::memcpy(&e.key[3], &ray.dir_x, 3 * sizeof(float));
  std::memcpy(&e.key[6], &ray.tfar, sizeof(float));
  e.answer = answer;
  return e;
}

std::size_t DbCache::slot(const Entry& e) const {
  uint64_t h = 0x9E3779B97F4A7C15ull;
  for (uint32_t w : e.key) {
    h = (h ^ w) * 0xBF58476D1CE4E5B9ull;
    h ^= h >> 31;
  }
  std::size_t mask = table_.size() - 1;
  std::size_t i = h & mask;
  while (table_[i].answer != unknown && table_[i].key != e.key) i = (i + 1) & mask;
  return i;
}

DbCache::Answer DbCache::find(const RTCRay& ray) const {
  if (entries_ == 0) return unknown;
  return Answer(table_[slot(entry(ray, unknown))].answer);
}

void DbCache::stage(const RTCRay* rays, const unsigned* which, const RTCRay* traced, unsigned count, unsigned hits) {
  std::lock_guard<std::mutex> lock(mutex_);
  counts_.hits += hits;
  counts_.misses += count;
  std::size_t limit = max_slots_ / 2;  // what the table can hold
  count = unsigned(std::min<std::size_t>(count, limit - std::min(limit, staged_.size())));
  if (staged_.size() + count > staged_.capacity())  // grown by hand: doubling must not pass the cap
    staged_.reserve(std::min(limit, std::max<std::size_t>(2 * staged_.capacity(), staged_.size() + count)));
  for (unsigned k = 0; k < count; ++k)
    staged_.push_back(entry(rays[which[k]], traced[k].tfar < 0 ? DbCache::blocked : clear));
}

void DbCache::insert(const Entry& e) {
  Entry& s = table_[slot(e)];
  if (s.answer == unknown) ++entries_;
  s = e;
}

void DbCache::resize(std::size_t slots) {
  std::vector<Entry> old(slots);
  old.swap(table_);
  entries_ = 0;
  for (const Entry& e : old)
    if (e.answer != unknown) insert(e);
}

void DbCache::commit() {
  if (staged_.empty()) return;
  std::size_t limit = max_slots_ / 2;
  if (entries_ + staged_.size() > limit) {  // full: start over with these
    std::fill(table_.begin(), table_.end(), Entry());
    entries_ = 0;
  }
  std::size_t slots = std::max(kFirstSlots, table_.size());
  while (slots < max_slots_ && slots < 2 * (entries_ + staged_.size())) slots *= 2;
  slots = std::min(slots, max_slots_);
  if (slots != table_.size()) resize(slots);
  for (const Entry& e : staged_) insert(e);
  std::vector<Entry>().swap(staged_);
}

DbCache::Counts DbCache::take_counts() {
  Counts c = counts_;
  counts_ = Counts();
  return c;
}

std::size_t DbCache::bytes() const { return (table_.capacity() + staged_.capacity()) * sizeof(Entry); }

}  // namespace radiosity
