#include "slam/util/thread_priority.h"

#include <algorithm>
#include <cerrno>
#include <cstring>

#if defined(__linux__)
#include <sys/resource.h>
#include <sys/syscall.h>
#include <pthread.h>
#include <sched.h>
#include <unistd.h>
#endif

namespace lcv::slam {
namespace {

#if defined(__linux__)
// The kernel's thread id (glibc < 2.30 has no gettid wrapper).
id_t ThreadId() { return static_cast<id_t>(syscall(SYS_gettid)); }
#endif

}  // namespace

bool LowerCurrentThreadPriority(int nice_increment, std::string* error) {
  if (nice_increment < 0 || nice_increment > 19) {
    if (error != nullptr) {
      *error = "nice increment " + std::to_string(nice_increment) + " is outside 0..19";
    }
    return false;
  }
#if defined(__linux__)
  // A thread started by a real-time thread inherits its policy, under which nice values mean
  // nothing: background work goes back to normal scheduling first.
  if (CurrentThreadRealtimePriority() > 0 && !UseNormalScheduling(error)) return false;
  if (nice_increment == 0) return true;
  const int target = std::min(19, CurrentThreadNice() + nice_increment);
  if (setpriority(PRIO_PROCESS, ThreadId(), target) != 0) {
    if (error != nullptr) *error = std::string("setpriority: ") + std::strerror(errno);
    return false;
  }
  return true;
#else
  if (nice_increment == 0) return true;
  if (error != nullptr) *error = "per-thread priorities are not supported on this system";
  return false;
#endif
}

bool UseRealtimeScheduling(int fifo_priority, std::string* error) {
#if defined(__linux__)
  const int low = sched_get_priority_min(SCHED_FIFO), high = sched_get_priority_max(SCHED_FIFO);
  if (fifo_priority < low || fifo_priority > high) {
    if (error != nullptr) {
      *error = "real-time priority " + std::to_string(fifo_priority) + " is outside " +
               std::to_string(low) + ".." + std::to_string(high);
    }
    return false;
  }
  sched_param param{};
  param.sched_priority = fifo_priority;
  const int status = pthread_setschedparam(pthread_self(), SCHED_FIFO, &param);
  if (status != 0) {
    if (error != nullptr) {
      *error = std::string("SCHED_FIFO: ") + std::strerror(status) +
               (status == EPERM ? " (needs CAP_SYS_NICE or a large enough RLIMIT_RTPRIO)" : "");
    }
    return false;
  }
  return true;
#else
  (void)fifo_priority;
  if (error != nullptr) *error = "real-time scheduling is not supported on this system";
  return false;
#endif
}

bool UseNormalScheduling(std::string* error) {
#if defined(__linux__)
  if (CurrentThreadRealtimePriority() == 0) return true;
  sched_param param{};
  param.sched_priority = 0;
  const int status = pthread_setschedparam(pthread_self(), SCHED_OTHER, &param);
  if (status != 0) {
    if (error != nullptr) *error = std::string("SCHED_OTHER: ") + std::strerror(status);
    return false;
  }
#else
  (void)error;
#endif
  return true;
}

int CurrentThreadRealtimePriority() {
#if defined(__linux__)
  int policy = 0;
  sched_param param{};
  if (pthread_getschedparam(pthread_self(), &policy, &param) != 0) return 0;
  return policy == SCHED_FIFO || policy == SCHED_RR ? param.sched_priority : 0;
#else
  return 0;
#endif
}

int CurrentThreadNice() {
#if defined(__linux__)
  // getpriority returns -1 both as a value and as an error: errno tells them apart.
  errno = 0;
  const int nice = getpriority(PRIO_PROCESS, ThreadId());
  return errno == 0 ? nice : 0;
#else
  return 0;
#endif
}

}  // namespace lcv::slam
