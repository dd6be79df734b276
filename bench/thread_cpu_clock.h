#pragma once
// CPU time of the calling thread for the micro-benchmarks: the machine is shared, so wall time
// also counts other processes' turns; the benches print both where it matters.
#include <ctime>

namespace lcv::bench {

// Milliseconds of CPU time this thread has used (CLOCK_THREAD_CPUTIME_ID).
inline double ThreadCpuMs() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

}  // namespace lcv::bench
