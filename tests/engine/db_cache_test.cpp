// The dB cache on its own: exact keys, forgetting on another object's move, the memory cap.
#include "db_cache.h"
#include "visibility.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <vector>

namespace radiosity {
namespace {

RTCRay ray(int i, float tfar = 0.75f) {
  return make_ray(dvec3(0.1 * (i / 7), 0.2, 0.3), dvec3(1.0, 0.5 * i, -0.25), tfar);  // seven from each origin
}

DbCache::Answer find(const DbCache& cache, const RTCRay& ray) {
  DbCache::Answer a;
  cache.find(&ray, 1, &a);
  return a;
}

// Stages rays i0..i1-1 as one gather would, answered blocked where i is odd, and commits them.
void answer(DbCache& cache, int i0, int i1) {
  std::vector<RTCRay> asked, traced;
  std::vector<unsigned> which;
  for (int i = i0; i < i1; ++i) {
    asked.push_back(ray(i));
    traced.push_back(ray(i));
    if (i % 2) traced.back().tfar = -INFINITY;
    which.push_back(unsigned(which.size()));
  }
  cache.stage(asked.data(), which.data(), traced.data(), unsigned(asked.size()), 0);
  cache.commit();
}

TEST(DbCache, KeepsWhatWasTracedForTheExactRay) {
  DbCache cache(1.0);
  cache.own(3);
  EXPECT_EQ(find(cache, ray(1)), DbCache::unknown);
  answer(cache, 0, 100);
  EXPECT_EQ(cache.entries(), 100u);
  EXPECT_EQ(find(cache, ray(1)), DbCache::blocked);
  EXPECT_EQ(find(cache, ray(2)), DbCache::clear);
  // Asked many at once, as a batch asks (runs from one origin, then another; some not known).
  std::vector<RTCRay> asked;
  for (int i = 90; i < 120; ++i) asked.push_back(ray(i));
  std::vector<DbCache::Answer> known(asked.size());
  cache.find(asked.data(), unsigned(asked.size()), known.data());
  for (int i = 90; i < 120; ++i)
    EXPECT_EQ(known[i - 90], i >= 100 ? DbCache::unknown : i % 2 ? DbCache::blocked : DbCache::clear) << i;
  // One bit off in any part of the ray: another ray.
  float tfar = 0.75f;
  uint32_t bits;
  std::memcpy(&bits, &tfar, sizeof bits);
  ++bits;
  std::memcpy(&tfar, &bits, sizeof bits);
  EXPECT_EQ(find(cache, ray(1, tfar)), DbCache::unknown);
  RTCRay moved = ray(1);
  moved.org_y = std::nextafter(moved.org_y, 1.0f);
  EXPECT_EQ(find(cache, moved), DbCache::unknown);
  DbCache::Counts counts = cache.take_counts();
  EXPECT_EQ(counts.misses, 100);
  EXPECT_EQ(cache.take_counts().misses, 0);
}

TEST(DbCache, ForgetsWhenAnotherObjectChanges) {
  DbCache cache(1.0);
  cache.own(3);
  answer(cache, 0, 10);
  cache.own(3);  // the same object again: what else blocks its rays has not changed
  EXPECT_EQ(find(cache, ray(1)), DbCache::blocked);
  cache.own(4);
  EXPECT_EQ(cache.entries(), 0u);
  EXPECT_EQ(find(cache, ray(1)), DbCache::unknown);
}

TEST(DbCache, StaysUnderItsCapAndKeepsTheNewest) {
  const double cap = 4096;
  DbCache cache(cap / (1024 * 1024));
  cache.own(0);
  for (int i = 0; i < 1000; i += 20) {
    answer(cache, i, i + 20);
    EXPECT_LE(cache.bytes(), cap);
    EXPECT_EQ(find(cache, ray(i + 19)), DbCache::blocked);  // the latest are always there
  }
  EXPECT_LT(cache.entries(), 1000u);
  answer(cache, 0, 1000);  // more than it can hold: some kept, the rest traced again next time
  EXPECT_LE(cache.bytes(), cap);
  EXPECT_GT(cache.entries(), 0u);
}

TEST(DbCache, ZeroIsNoCache) {
  DbCache cache(0.0);
  cache.own(0);
  answer(cache, 0, 10);
  EXPECT_EQ(cache.entries(), 0u);
  EXPECT_EQ(cache.bytes(), 0u);
  EXPECT_EQ(find(cache, ray(1)), DbCache::unknown);
  EXPECT_EQ(cache.take_counts().misses, 10);
}

}  // namespace
}  // namespace radiosity
