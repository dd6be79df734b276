#include "slam/util/thread_clock.h"

#include <ctime>

#if defined(__linux__)
#include <sys/resource.h>
#endif

namespace lcv::slam {

ThreadClock ThreadClock::Now() {
  ThreadClock clock;
  clock.wall = std::chrono::steady_clock::now();
#if defined(__linux__)
  timespec cpu{};
  if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &cpu) == 0) {
    clock.cpu_ms = static_cast<double>(cpu.tv_sec) * 1e3 + static_cast<double>(cpu.tv_nsec) * 1e-6;
  }
  rusage usage{};
  if (getrusage(RUSAGE_THREAD, &usage) == 0) clock.involuntary_switches = usage.ru_nivcsw;
#endif
  return clock;
}

}  // namespace lcv::slam
