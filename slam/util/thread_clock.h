#pragma once
// Where a thread's time goes (issue 14: which frames make tracking's p99, and why). Three clocks
// of the calling thread, read together:
//   - wall time (steady_clock);
//   - the thread's own CPU time (CLOCK_THREAD_CPUTIME_ID): work done, not counting time the
//     thread was runnable but waiting for a core, nor work other threads did for it;
//   - its involuntary context switches (getrusage RUSAGE_THREAD): how often the scheduler took
//     the core away from it (another thread or process ran instead).
// A frame whose wall time is far above its CPU time, with involuntary switches, waited for a
// core; one whose CPU time is high did more work.
//
//   ThreadClock start = ThreadClock::Now();
//   ...
//   ThreadClockSpan span = ThreadClock::Now() - start;   // span.wall_ms, span.cpu_ms, span.preemptions
//
//   double stage_ms = 0.0;
//   { StageTimer timer(&stage_ms); ... }                // adds the block's wall time to stage_ms
//
// Units: milliseconds. Linux: all three; elsewhere cpu_ms is 0 and preemptions 0. Thread safety:
// each reading concerns the calling thread only; values are plain data.

#include <chrono>

namespace lcv::slam {

struct ThreadClockSpan {
  double wall_ms = 0.0;
  double cpu_ms = 0.0;
  long preemptions = 0;  // involuntary context switches

  ThreadClockSpan& operator+=(const ThreadClockSpan& other) {
    wall_ms += other.wall_ms;
    cpu_ms += other.cpu_ms;
    preemptions += other.preemptions;
    return *this;
  }
  ThreadClockSpan operator-(const ThreadClockSpan& other) const {
    return {wall_ms - other.wall_ms, cpu_ms - other.cpu_ms, preemptions - other.preemptions};
  }
};

struct ThreadClock {
  std::chrono::steady_clock::time_point wall;
  double cpu_ms = 0.0;
  long involuntary_switches = 0;

  // The calling thread's three clocks now (two system calls, ~1 us).
  static ThreadClock Now();
  ThreadClockSpan operator-(const ThreadClock& earlier) const {
    return {std::chrono::duration<double, std::milli>(wall - earlier.wall).count(),
            cpu_ms - earlier.cpu_ms, involuntary_switches - earlier.involuntary_switches};
  }
};

// Adds the wall time from construction to Stop() (or destruction) to *total_ms.
class StageTimer {
 public:
  explicit StageTimer(double* total_ms)
      : total_ms_(total_ms), start_(std::chrono::steady_clock::now()) {}
  ~StageTimer() { Stop(); }
  StageTimer(const StageTimer&) = delete;
  StageTimer& operator=(const StageTimer&) = delete;
  void Stop() {
    if (total_ms_ == nullptr) return;
    *total_ms_ += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() -
                                                            start_).count();
    total_ms_ = nullptr;
  }

 private:
  double* total_ms_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace lcv::slam
