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
