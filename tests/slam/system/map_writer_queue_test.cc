// MapWriterQueue (slam/map_writer_queue.h): keyframes are bounded and refused (live) or waited
// for (offline); other tasks keep their place in the order. No timed assertions.
#include "slam/map_writer_queue.h"

#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace lcv::slam {
namespace {

Frame KeyframeCandidate(Id id) {
  Frame frame;
  frame.id = id;
  return frame;
}

TEST(MapWriterQueue, LiveKeyframesAreRefusedWhenTheQueueIsFull) {
  MapWriterQueue queue(1);
  EXPECT_TRUE(queue.Idle());
  EXPECT_TRUE(queue.PushKeyframe(KeyframeCandidate(1), /*wait=*/false));
  EXPECT_FALSE(queue.Idle());
  // Mapping behind: the next candidate is refused, not queued, and left to the caller.
  Frame refused = KeyframeCandidate(2);
  EXPECT_FALSE(queue.PushKeyframe(std::move(refused), /*wait=*/false));
  EXPECT_EQ(refused.id, 2);
  EXPECT_EQ(queue.keyframes_queued(), 1);
  // Other tasks are not keyframes and still go in.
  EXPECT_TRUE(queue.PushTask([] {}));
  // The writer takes the keyframe: there is room again while it maps it, but it is not idle.
  std::optional<MapWriterQueue::Task> task = queue.Pop();
  ASSERT_TRUE(task && task->keyframe);
  EXPECT_EQ(task->keyframe->id, 1);
  EXPECT_FALSE(queue.Idle());
  EXPECT_TRUE(queue.PushKeyframe(KeyframeCandidate(3), /*wait=*/false));
  EXPECT_FALSE(queue.PushKeyframe(KeyframeCandidate(4), /*wait=*/false));
  queue.Done();
  // Stopped: refused, the frame again left as it was.
  queue.Stop();
  Frame after_stop = KeyframeCandidate(5);
  EXPECT_FALSE(queue.PushKeyframe(std::move(after_stop), /*wait=*/false));
  EXPECT_EQ(after_stop.id, 5);
}

TEST(MapWriterQueue, TasksRunInTheOrderQueued) {
  // A reset queued after a keyframe must come after it.
  MapWriterQueue queue(2);
  std::vector<int> order;
  ASSERT_TRUE(queue.PushKeyframe(KeyframeCandidate(10), false));
  ASSERT_TRUE(queue.PushTask([&] { order.push_back(-1); }));
  ASSERT_TRUE(queue.PushKeyframe(KeyframeCandidate(11), false));
  queue.Stop();
  while (std::optional<MapWriterQueue::Task> task = queue.Pop()) {
    if (task->keyframe) {
      order.push_back(static_cast<int>(task->keyframe->id));
    } else {
      task->work();
    }
    queue.Done();
  }
  EXPECT_EQ(order, (std::vector<int>{10, -1, 11}));
  EXPECT_FALSE(queue.PushTask([] {}));
}

TEST(MapWriterQueue, OfflineKeyframesWaitForRoomAndNeverExceedTheCapacity) {
  constexpr int kKeyframes = 300;
  MapWriterQueue queue(1);
  std::thread tracking([&] {
    for (int i = 0; i < kKeyframes; ++i) {
      ASSERT_TRUE(queue.PushKeyframe(KeyframeCandidate(i), /*wait=*/true));
    }
    queue.Stop();
  });
  int largest = 0;
  std::vector<Id> mapped;
  while (std::optional<MapWriterQueue::Task> task = queue.Pop()) {
    largest = std::max(largest, queue.keyframes_queued());  // never above the capacity
    mapped.push_back(task->keyframe->id);
    queue.Done();
  }
  tracking.join();
  ASSERT_EQ(mapped.size(), static_cast<std::size_t>(kKeyframes));
  for (int i = 0; i < kKeyframes; ++i) EXPECT_EQ(mapped[i], i);
  EXPECT_LE(largest, 1);
}

}  // namespace
}  // namespace lcv::slam
