#pragma once
// A minimal fork-join loop over an index range for the audit's per-line passes. Each worker gets
// one contiguous block of indices (so per-worker results can be concatenated in index order and
// the output does not depend on scheduling) and its worker number (for per-worker scratch
// buffers). The machine has 2 cores; the audits are memory bound, so blocks are static.

#include <algorithm>
#include <cstddef>
#include <thread>
#include <vector>

namespace lcv::privacy {

// Threads to use for num_threads <= 0: the hardware concurrency (at least 1).
inline int ResolveThreadCount(int num_threads) {
  if (num_threads > 0) return num_threads;
  return std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

// Calls body(begin, end, worker) for num_workers contiguous blocks of [0, count), worker 0 on the
// calling thread. Exceptions must not escape body (the audits' bodies do not throw).
template <typename Body>
void ParallelBlocks(std::size_t count, int num_workers, Body&& body) {
  num_workers = std::max(1, std::min<int>(num_workers, static_cast<int>(std::max<std::size_t>(count, 1))));
  if (num_workers == 1) {
    body(std::size_t{0}, count, 0);
    return;
  }
  std::vector<std::thread> threads;
  const std::size_t block = (count + num_workers - 1) / num_workers;
  for (int w = 1; w < num_workers; ++w) {
    const std::size_t begin = std::min(count, w * block);
    const std::size_t end = std::min(count, begin + block);
    threads.emplace_back([&body, begin, end, w] { body(begin, end, w); });
  }
  body(std::size_t{0}, std::min(count, block), 0);
  for (auto& t : threads) t.join();
}

}  // namespace lcv::privacy
