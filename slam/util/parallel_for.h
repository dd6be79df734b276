#pragma once
// Data-parallel loops for the tracking thread's heaviest stage (the line cloud's discretized
// line search, slam/match/line_projection_matcher.h): a pool of helper threads that the calling
// thread joins for the length of one loop.
//
//   ParallelFor pool(2);                       // the caller and one helper
//   pool.Run(n, 16, [&](int begin, int end, int worker) { ... });
//
// Run calls the function on chunks [begin, end) of [0, n), chunk by chunk as the threads become
// free (dynamic scheduling: the work per index may vary a lot), each index exactly once, and
// returns when every chunk is done. `worker` is 0 for the caller and 1..num_threads()-1 for the
// helpers: per-worker scratch is indexed by it. Which worker runs which chunk is not
// deterministic, so a deterministic result must be written per index and combined by the
// caller afterwards.
//
// Helpers are started on the first Run (by the thread that calls it: they inherit its
// scheduling policy, e.g. the live tracking thread's SCHED_FIFO) and sleep on a condition
// variable between loops; they never spin. The caller, done with the chunks, polls for up to
// 50 us for the helpers to finish theirs before it sleeps too: on a 2-core VM a wake-up through
// the condition variable took tens of microseconds, as long as a whole short loop.
// With num_threads <= 1 Run is a plain loop on the caller. The function must not throw.
//
// Thread safety: one caller at a time (the owner); not reentrant.

#include <atomic>
#include <cstdint>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace lcv::slam {

class ParallelFor {
 public:
  explicit ParallelFor(int num_threads);
  ~ParallelFor();
  ParallelFor(const ParallelFor&) = delete;
  ParallelFor& operator=(const ParallelFor&) = delete;

  int num_threads() const { return num_threads_; }

  void Run(int n, int chunk, const std::function<void(int begin, int end, int worker)>& fn);

 private:
  void HelperLoop(int worker);
  void RunChunks(int worker);

  const int num_threads_;
  std::vector<std::thread> helpers_;
  std::mutex mutex_;
  std::condition_variable work_ready_;
  std::condition_variable work_done_;
  // The current loop (valid while helpers_busy_ > 0 or the caller runs chunks).
  const std::function<void(int, int, int)>* fn_ = nullptr;
  int n_ = 0;
  int chunk_ = 1;
  std::atomic<int> next_{0};
  std::uint64_t generation_ = 0;  // guarded by mutex_
  // Helpers still in the current loop: written under mutex_ when a loop starts, decremented
  // by each helper as it leaves (the last one notifies work_done_ under mutex_); the caller
  // polls it for a few microseconds before it sleeps (see Run).
  std::atomic<int> helpers_busy_{0};
  bool stop_ = false;             // guarded by mutex_
};

}  // namespace lcv::slam
