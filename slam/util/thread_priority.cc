#include "slam/util/thread_priority.h"

#include <algorithm>
#include <cerrno>
#include <cstring>

#if defined(__linux__)
#include <sys/resource.h>
#include <sys/syscall.h>
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
  if (nice_increment == 0) return true;
#if defined(__linux__)
  const int target = std::min(19, CurrentThreadNice() + nice_increment);
  if (setpriority(PRIO_PROCESS, ThreadId(), target) != 0) {
    if (error != nullptr) *error = std::string("setpriority: ") + std::strerror(errno);
    return false;
  }
  return true;
#else
  if (error != nullptr) *error = "per-thread priorities are not supported on this system";
  return false;
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
