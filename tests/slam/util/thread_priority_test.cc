// Thread priorities and clocks of the engine's threads (slam/util/thread_priority.h,
// slam/util/thread_clock.h; issue 14). Behaviour only, no timed assertions: a lowered priority
// is read back from the system, and the clocks are checked for order, not for durations.
#include <algorithm>
#include <chrono>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "slam/util/thread_clock.h"
#include "slam/util/thread_priority.h"

namespace lcv::slam {
namespace {

#if defined(__linux__)
TEST(ThreadPriority, LowersOnlyTheCallingThreadAndClampsAt19) {
  const int caller_nice = CurrentThreadNice();
  int lowered = -100, clamped = -100;
  bool ok_lowered = false, ok_clamped = false;
  std::thread worker([&] {
    ok_lowered = LowerCurrentThreadPriority(3);
    lowered = CurrentThreadNice();
    ok_clamped = LowerCurrentThreadPriority(19);
    clamped = CurrentThreadNice();
  });
  worker.join();
  ASSERT_TRUE(ok_lowered);
  EXPECT_EQ(lowered, std::min(19, caller_nice + 3));
  ASSERT_TRUE(ok_clamped);
  EXPECT_EQ(clamped, 19);
  EXPECT_EQ(CurrentThreadNice(), caller_nice) << "the caller's priority is its own";
}

TEST(ThreadPriority, ThreadsCreatedByALoweredThreadInheritIt) {
  int child_nice = -100;
  int parent_nice = -100;
  std::thread parent([&] {
    LowerCurrentThreadPriority(5);
    parent_nice = CurrentThreadNice();
    std::thread child([&] { child_nice = CurrentThreadNice(); });
    child.join();
  });
  parent.join();
  EXPECT_EQ(child_nice, parent_nice);
}

// Real-time scheduling (lcv slam --realtime's tracking thread). Where the system refuses it (no
// CAP_SYS_NICE, RLIMIT_RTPRIO 0) the refusal is reported and nothing changes; where it is
// granted, it is the calling thread's own, a background thread it starts returns to normal
// scheduling when it lowers its priority, and the caller can leave it again.
TEST(ThreadPriority, RealtimeSchedulingIsTheCallersOwnAndBackgroundThreadsLeaveIt) {
  bool granted = false;
  std::string error;
  int inside = -1, after_normal = -1, child_inherited = -1, child_after_lower = -1;
  int child_nice = -100, parent_nice = -100;
  std::thread parent([&] {
    granted = UseRealtimeScheduling(7, &error);
    inside = CurrentThreadRealtimePriority();
    parent_nice = CurrentThreadNice();
    std::thread child([&] {
      child_inherited = CurrentThreadRealtimePriority();
      LowerCurrentThreadPriority(3);
      child_after_lower = CurrentThreadRealtimePriority();
      child_nice = CurrentThreadNice();
    });
    child.join();
    EXPECT_TRUE(UseNormalScheduling());
    after_normal = CurrentThreadRealtimePriority();
  });
  parent.join();
  EXPECT_EQ(CurrentThreadRealtimePriority(), 0) << "the test's own thread is untouched";
  EXPECT_EQ(after_normal, 0);
  if (!granted) {
    EXPECT_NE(error.find("SCHED_FIFO"), std::string::npos) << error;
    EXPECT_EQ(inside, 0);
    return;
  }
  EXPECT_EQ(inside, 7);
  EXPECT_EQ(child_inherited, 7) << "threads inherit their creator's policy";
  EXPECT_EQ(child_after_lower, 0) << "a lowered background thread runs under normal scheduling";
  EXPECT_EQ(child_nice, std::min(19, parent_nice + 3));
}

TEST(ThreadPriority, RealtimePriorityOutOfRangeIsRefusedWithAReason) {
  for (int priority : {0, 100}) {
    std::string error;
    EXPECT_FALSE(UseRealtimeScheduling(priority, &error)) << priority;
    EXPECT_NE(error.find(std::to_string(priority)), std::string::npos) << error;
    EXPECT_EQ(CurrentThreadRealtimePriority(), 0);
  }
}
#endif

TEST(ThreadPriority, ZeroIsANoOpAndOutOfRangeIsRefusedWithAReason) {
  const int before = CurrentThreadNice();
  EXPECT_TRUE(LowerCurrentThreadPriority(0));
  EXPECT_EQ(CurrentThreadNice(), before);
  std::string error;
  EXPECT_FALSE(LowerCurrentThreadPriority(20, &error));
  EXPECT_NE(error.find("20"), std::string::npos) << error;
  EXPECT_FALSE(LowerCurrentThreadPriority(-1, &error));
  EXPECT_EQ(CurrentThreadNice(), before);
}

#if defined(__linux__)
TEST(ThreadClock, CountsWorkAsCpuTimeAndSleepAsWallTimeOnly) {
  const ThreadClock start = ThreadClock::Now();
  volatile double sink = 0.0;
  for (int i = 0; i < 2000000; ++i) sink = sink + 1e-9 * i;
  const ThreadClock worked = ThreadClock::Now();
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  const ThreadClock slept = ThreadClock::Now();
  const ThreadClockSpan work = worked - start;
  const ThreadClockSpan sleep = slept - worked;
  EXPECT_GT(work.cpu_ms, 0.0);
  EXPECT_GE(work.wall_ms, 0.0);
  EXPECT_GT(sleep.wall_ms, 0.0);
  EXPECT_LT(sleep.cpu_ms, sleep.wall_ms) << "a sleeping thread uses no CPU";
  EXPECT_GE(sleep.preemptions, 0);
  ThreadClockSpan total = work;
  total += sleep;
  EXPECT_DOUBLE_EQ(total.wall_ms, work.wall_ms + sleep.wall_ms);
}
#endif

TEST(StageTimer, AddsToItsTotalOnceWhenStoppedOrDestroyed) {
  double total = 0.0;
  {
    StageTimer timer(&total);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    timer.Stop();
    const double stopped = total;
    EXPECT_GT(stopped, 0.0);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    timer.Stop();  // a second Stop adds nothing
    EXPECT_EQ(total, stopped);
  }
  const double after_first = total;
  { StageTimer timer(&total); }
  EXPECT_GE(total, after_first) << "destruction adds the block's time";
}

}  // namespace
}  // namespace lcv::slam
