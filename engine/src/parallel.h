// How the engine shares work across cores: oneTBB, in an arena of the Solver's own.
//
// Its threads sleep when they run out of work instead of spinning at a barrier, so that a solve next
// to other busy processes (Blender drawing, a Cycles render, a second bake, a farm's workers) gets its
// fair share of the machine: a thread spinning for one that is descheduled burns the time slice the
// other needs. Embree builds its BVHs with the same scheduler, so inside the arena they keep to its
// threads. OpenMP's wait policy would be the other way, but Blender loads libgomp and reads it at start.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <utility>

namespace radiosity {

// The threads one Solver works on: `threads` of them, or every core for 0.
class Workers {
 public:
  explicit Workers(int threads) : arena_(concurrency(threads)) {}
  void resize(int threads) {
    arena_.terminate();
    arena_.initialize(concurrency(threads));
  }
  // Runs `work` on the calling thread, with the arena's threads to share its parallel loops.
  template <class Work>
  decltype(auto) run(Work&& work) {
    return arena_.execute(std::forward<Work>(work));
  }

 private:
  static int concurrency(int threads) { return threads > 0 ? threads : tbb::task_arena::automatic; }
  tbb::task_arena arena_;
};

// body(i) for i in [begin, end), in chunks of about `grain` indices shared across the current arena.
template <class Body>
void parallel_for(int begin, int end, int grain, Body&& body) {
  tbb::parallel_for(tbb::blocked_range<int>(begin, end, grain), [&](const tbb::blocked_range<int>& r) {
    for (int i = r.begin(); i < r.end(); ++i) body(i);
  });
}

}  // namespace radiosity
