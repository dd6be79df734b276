#include "slam/util/parallel_for.h"

#include <algorithm>
#include <chrono>

namespace lcv::slam {

ParallelFor::ParallelFor(int num_threads) : num_threads_(std::max(1, num_threads)) {}

ParallelFor::~ParallelFor() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  work_ready_.notify_all();
  for (std::thread& helper : helpers_) helper.join();
}

void ParallelFor::RunChunks(int worker) {
  for (;;) {
    const int begin = next_.fetch_add(chunk_, std::memory_order_relaxed);
    if (begin >= n_) return;
    (*fn_)(begin, std::min(n_, begin + chunk_), worker);
  }
}

void ParallelFor::HelperLoop(int worker) {
  std::uint64_t seen = 0;
  for (;;) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      work_ready_.wait(lock, [&] { return stop_ || generation_ != seen; });
      if (stop_) return;
      seen = generation_;
    }
    RunChunks(worker);
    if (helpers_busy_.fetch_sub(1, std::memory_order_acq_rel) == 1) {
      // The caller may be asleep on work_done_: notify under the mutex, so that it either has
      // not checked the count yet or is already waiting.
      std::lock_guard<std::mutex> lock(mutex_);
      work_done_.notify_one();
    }
  }
}

void ParallelFor::Run(int n, int chunk,
                      const std::function<void(int begin, int end, int worker)>& fn) {
  if (n <= 0) return;
  chunk = std::max(1, chunk);
  if (num_threads_ <= 1 || n <= chunk) {
    for (int begin = 0; begin < n; begin += chunk) fn(begin, std::min(n, begin + chunk), 0);
    return;
  }
  if (helpers_.empty()) {
    for (int w = 1; w < num_threads_; ++w) helpers_.emplace_back([this, w] { HelperLoop(w); });
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    fn_ = &fn;
    n_ = n;
    chunk_ = chunk;
    next_.store(0, std::memory_order_relaxed);
    helpers_busy_.store(num_threads_ - 1, std::memory_order_relaxed);
    ++generation_;
  }
  work_ready_.notify_all();
  RunChunks(0);
  // The helpers are at most one chunk from done once they run; poll before sleeping.
  const auto poll_until = std::chrono::steady_clock::now() + std::chrono::microseconds(50);
  for (int polls = 0; helpers_busy_.load(std::memory_order_acquire) != 0; ++polls) {
    if ((polls & 63) == 63 && std::chrono::steady_clock::now() > poll_until) break;
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();  // leaves the core's resources to a helper on a sibling thread
#endif
  }
  std::unique_lock<std::mutex> lock(mutex_);
  work_done_.wait(lock, [&] { return helpers_busy_.load(std::memory_order_acquire) == 0; });
  fn_ = nullptr;
}

}  // namespace lcv::slam
