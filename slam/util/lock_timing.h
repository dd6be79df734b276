#pragma once
// Measures how long a thread holds a lock (the engine's stats: map_lock_ms per thread, issue 14).
//
//   LockHoldRecorder recorder;                 // one per thread role, written by that thread only
//   { TimedLock lock(mutex, &recorder); ... }  // records the time from acquisition to release
//   LockHoldSummary s = recorder.Summary();    // after the thread is joined (or on that thread)
//
// Thread safety: a recorder is not synchronized; only the thread that owns it records into it or
// reads it, others read it after joining that thread. Waiting for the lock is not counted: the
// figure is how long the holder kept others out.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <mutex>
#include <vector>

namespace lcv::slam {

struct LockHoldSummary {
  int count = 0;        // acquisitions
  double max_ms = 0.0;  // longest hold
  double p99_ms = 0.0;  // 99th percentile (nearest rank) of the holds
};

class LockHoldRecorder {
 public:
  void Add(double hold_ms) {
    samples_ms_.push_back(static_cast<float>(hold_ms));
    max_ms_ = std::max(max_ms_, hold_ms);
  }
  LockHoldSummary Summary() const {
    LockHoldSummary s;
    s.count = static_cast<int>(samples_ms_.size());
    if (samples_ms_.empty()) return s;
    std::vector<float> sorted = samples_ms_;
    const std::size_t rank = static_cast<std::size_t>(std::ceil(0.99 * sorted.size())) - 1;
    std::nth_element(sorted.begin(), sorted.begin() + rank, sorted.end());
    s.p99_ms = sorted[rank];
    s.max_ms = max_ms_;
    return s;
  }

 private:
  std::vector<float> samples_ms_;
  double max_ms_ = 0.0;
};

// std::lock_guard that records its hold time into a recorder (nullptr: not recorded).
class TimedLock {
 public:
  TimedLock(std::mutex& mutex, LockHoldRecorder* recorder) : lock_(mutex), recorder_(recorder) {
    acquired_ = std::chrono::steady_clock::now();
  }
  ~TimedLock() {
    if (recorder_ == nullptr) return;
    const auto released = std::chrono::steady_clock::now();
    // Recorded after the release: the recorder's bookkeeping (a vector that may grow) is not
    // part of the hold.
    lock_.unlock();
    recorder_->Add(std::chrono::duration<double, std::milli>(released - acquired_).count());
  }
  TimedLock(const TimedLock&) = delete;
  TimedLock& operator=(const TimedLock&) = delete;

 private:
  std::unique_lock<std::mutex> lock_;
  LockHoldRecorder* recorder_;
  std::chrono::steady_clock::time_point acquired_;
};

}  // namespace lcv::slam
