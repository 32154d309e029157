// The dB cache on its own: exact keys, per object, forgetting what another object's move may block,
// the memory cap.
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

DbCache::Answer find(const DbCache& cache, const RTCRay& ray, int object = 3) {
  DbCache::Answer a;
  cache.find(object, &ray, 1, &a);
  return a;
}

// Stages rays i0..i1-1 as a gather of `object` would, answered blocked where i is odd.
void stage(DbCache& cache, int i0, int i1, int object) {
  std::vector<RTCRay> asked, traced;
  std::vector<unsigned> which;
  for (int i = i0; i < i1; ++i) {
    asked.push_back(ray(i));
    traced.push_back(ray(i));
    if (i % 2) traced.back().tfar = -INFINITY;
    which.push_back(unsigned(which.size()));
  }
  cache.stage(object, asked.data(), which.data(), traced.data(), unsigned(asked.size()), 0);
}

// The same, committed: one gather of one object.
void answer(DbCache& cache, int i0, int i1, int object = 3) {
  stage(cache, i0, i1, object);
  cache.commit();
}

// A place of an object that ray(1) passes through (at t = 0.5) and ray(2) passes 0.25 from.
const Sphere kOnRay1{dvec3(0.5, 0.45, 0.175), 0.05};
const Sphere kAside{dvec3(-3.0, -3.0, -3.0), 0.05};

TEST(DbCache, KeepsWhatWasTracedForTheExactRay) {
  DbCache cache(1.0);
  EXPECT_EQ(find(cache, ray(1)), DbCache::unknown);
  answer(cache, 0, 100);
  EXPECT_EQ(cache.entries(), 100u);
  EXPECT_EQ(find(cache, ray(1)), DbCache::blocked);
  EXPECT_EQ(find(cache, ray(2)), DbCache::clear);
  // Asked many at once, as a batch asks (runs from one origin, then another; some not known).
  std::vector<RTCRay> asked;
  for (int i = 90; i < 120; ++i) asked.push_back(ray(i));
  std::vector<DbCache::Answer> known(asked.size());
  cache.find(3, asked.data(), unsigned(asked.size()), known.data());
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

TEST(DbCache, KeepsEachObjectsAnswersApart) {
  DbCache cache(1.0);
  answer(cache, 0, 10, 3);
  answer(cache, 5, 12, 4);
  EXPECT_EQ(cache.entries(), 17u);
  EXPECT_EQ(find(cache, ray(1), 3), DbCache::blocked);
  EXPECT_EQ(find(cache, ray(1), 4), DbCache::unknown);  // asked about the scene without 3 only
  EXPECT_EQ(find(cache, ray(11), 4), DbCache::blocked);
  EXPECT_EQ(find(cache, ray(11), 3), DbCache::unknown);
}

TEST(DbCache, KeepsTheAnswersOfObjectsMovedTogetherEachToItsOwn) {
  // One gather of several movers stages their answers interleaved, as its threads trace them.
  DbCache cache(1.0);
  stage(cache, 0, 5, 3);
  stage(cache, 20, 30, 4);
  stage(cache, 5, 10, 3);
  cache.commit();
  EXPECT_EQ(cache.entries(), 20u);
  EXPECT_EQ(find(cache, ray(1), 3), DbCache::blocked);
  EXPECT_EQ(find(cache, ray(8), 3), DbCache::clear);
  EXPECT_EQ(find(cache, ray(21), 4), DbCache::blocked);
  EXPECT_EQ(find(cache, ray(21), 3), DbCache::unknown);
  EXPECT_EQ(find(cache, ray(1), 4), DbCache::unknown);
  EXPECT_EQ(cache.take_counts().misses, 20);
}

TEST(DbCache, ObjectsMovedTogetherShareOneStagingCap) {
  const double cap = 4096;  // a quarter for staging: 32 answers
  DbCache cache(cap / (1024 * 1024));
  for (int object = 0; object < 4; ++object) {
    stage(cache, 0, 30, object);
    EXPECT_LE(cache.bytes(), cap / 4);
  }
  cache.commit();
  EXPECT_LE(cache.bytes(), cap);
  EXPECT_GT(cache.entries(), 0u);
  EXPECT_LE(cache.entries(), 32u);
}

TEST(DbCache, ForgetsOnlyWhatAnotherObjectsMoveMayBlock) {
  DbCache cache(1.0);
  answer(cache, 0, 10, 3);
  answer(cache, 0, 10, 4);
  cache.moved(3, {kOnRay1, kOnRay1});  // its own answers are about the scene without it
  EXPECT_EQ(find(cache, ray(1), 3), DbCache::blocked);
  EXPECT_EQ(find(cache, ray(2), 4), DbCache::unknown);  // not prepared since 3 moved
  cache.prepare(4);
  EXPECT_EQ(find(cache, ray(1), 4), DbCache::unknown);
  EXPECT_EQ(find(cache, ray(2), 4), DbCache::clear);
  EXPECT_EQ(cache.entries(), 19u);
  cache.moved(5, {kAside, kOnRay1});  // either place counts
  cache.prepare(3);
  EXPECT_EQ(find(cache, ray(1), 3), DbCache::unknown);
  EXPECT_EQ(find(cache, ray(3), 3), DbCache::blocked);
  cache.moved(5, {kAside, kAside});
  cache.prepare(3), cache.prepare(4);
  EXPECT_EQ(cache.entries(), 18u);
}

TEST(DbCache, StaysUnderItsCapAndKeepsTheNewest) {
  const double cap = 4096;
  DbCache cache(cap / (1024 * 1024));
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

TEST(DbCache, ItsCapHoldsOverAllObjectsAndTheOldestMoverGoesFirst) {
  const double cap = 8192;
  DbCache cache(cap / (1024 * 1024));
  for (int object = 0; object < 3; ++object) {
    cache.moved(object, {kAside, kAside});
    answer(cache, 0, 20, object);
  }
  cache.prepare(0);
  EXPECT_EQ(find(cache, ray(1), 0), DbCache::blocked);
  for (int round = 0; round < 10; ++round) {
    cache.moved(1 + round % 2, {kAside, kAside});  // objects 1 and 2 move on, 0 not
    answer(cache, 20 * round, 20 * round + 20, 1 + round % 2);
    EXPECT_LE(cache.bytes(), cap);
  }
  cache.prepare(0);
  EXPECT_EQ(find(cache, ray(1), 0), DbCache::unknown);
  EXPECT_EQ(find(cache, ray(199), 2), DbCache::blocked);
}

TEST(DbCache, ZeroIsNoCache) {
  DbCache cache(0.0);
  answer(cache, 0, 10);
  EXPECT_EQ(cache.entries(), 0u);
  EXPECT_EQ(cache.bytes(), 0u);
  EXPECT_EQ(find(cache, ray(1)), DbCache::unknown);
  EXPECT_EQ(cache.take_counts().misses, 10);
}

}  // namespace
}  // namespace radiosity
