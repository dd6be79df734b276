// BoundedQueue (slam/util/bounded_queue.h): never holds more than its capacity, whatever the
// producer's policy; drop-oldest keeps the newest items; Stop drains. No timed assertions: the
// threaded cases check order and bounds, not durations.
#include "slam/util/bounded_queue.h"

#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace lcv::slam {
namespace {

TEST(BoundedQueue, TryPushRefusesWhenFullAndAcceptsAfterPop) {
  BoundedQueue<int> queue(2);
  int a = 1, b = 2, c = 3;
  EXPECT_TRUE(queue.TryPush(std::move(a)));
  EXPECT_TRUE(queue.TryPush(std::move(b)));
  EXPECT_TRUE(queue.Full());
  EXPECT_FALSE(queue.TryPush(std::move(c)));
  EXPECT_EQ(queue.size(), 2u);
  EXPECT_EQ(*queue.Pop(), 1);
  queue.Done();
  int d = 4;
  EXPECT_TRUE(queue.TryPush(std::move(d)));
  EXPECT_EQ(*queue.Pop(), 2);
  queue.Done();
  EXPECT_EQ(*queue.Pop(), 4);
  queue.Done();
  EXPECT_TRUE(queue.Idle());
}

TEST(BoundedQueue, DropOldestKeepsTheNewestAndCountsDrops) {
  // A camera slot of one frame: tracking finds the newest image, never a backlog.
  BoundedQueue<int> slot(1);
  int dropped = 0;
  for (int frame = 0; frame < 5; ++frame) dropped += slot.PushDropOldest(frame);
  EXPECT_EQ(dropped, 4);
  EXPECT_EQ(slot.size(), 1u);
  EXPECT_EQ(*slot.TryPop(), 4);
  slot.Done();
  EXPECT_FALSE(slot.TryPop().has_value());
  EXPECT_EQ(slot.PushDropOldest(5), 0);
}

TEST(BoundedQueue, StopDrainsWhatIsLeftAndRefusesMore) {
  BoundedQueue<int> queue(3);
  EXPECT_TRUE(queue.Push(7));
  EXPECT_TRUE(queue.Push(8));
  queue.Stop();
  EXPECT_FALSE(queue.Push(9));
  int ten = 10;
  EXPECT_FALSE(queue.TryPush(std::move(ten)));
  EXPECT_EQ(*queue.Pop(), 7);
  EXPECT_EQ(*queue.Pop(), 8);
  EXPECT_FALSE(queue.Pop().has_value());
}

TEST(BoundedQueue, BlockingPushNeverExceedsCapacityAndKeepsOrder) {
  // A producer pushing faster than the consumer pops waits for room; the consumer checks the
  // bound on every item it takes.
  constexpr int kItems = 2000;
  BoundedQueue<int> queue(2);
  std::thread producer([&] {
    for (int i = 0; i < kItems; ++i) ASSERT_TRUE(queue.Push(i));
    queue.Stop();
  });
  std::vector<int> received;
  std::size_t largest = 0;
  while (std::optional<int> item = queue.Pop()) {
    largest = std::max(largest, queue.size());  // never above the capacity
    received.push_back(*item);
    queue.Done();
  }
  producer.join();
  ASSERT_EQ(received.size(), static_cast<std::size_t>(kItems));
  for (int i = 0; i < kItems; ++i) EXPECT_EQ(received[i], i);
  EXPECT_LE(largest, queue.capacity());
}

TEST(BoundedQueue, DropOldestUnderConcurrencyLosesOnlyOlderItems) {
  // Whatever the interleaving, the consumer sees increasing items, the last one among them, and
  // received + dropped = pushed.
  constexpr int kItems = 5000;
  BoundedQueue<int> slot(1);
  int dropped = 0;
  std::thread camera([&] {
    for (int i = 0; i < kItems; ++i) dropped += slot.PushDropOldest(i);
    slot.Stop();
  });
  std::vector<int> received;
  while (std::optional<int> item = slot.Pop()) {
    received.push_back(*item);
    slot.Done();
  }
  camera.join();
  ASSERT_FALSE(received.empty());
  EXPECT_EQ(received.back(), kItems - 1);
  for (std::size_t k = 1; k < received.size(); ++k) EXPECT_LT(received[k - 1], received[k]);
  EXPECT_EQ(static_cast<int>(received.size()) + dropped, kItems);
}

TEST(BoundedQueue, WaitIdleReturnsAfterTheConsumerIsDone) {
  BoundedQueue<int> queue(1);
  std::vector<int> done;
  std::thread consumer([&] {
    while (std::optional<int> item = queue.Pop()) {
      done.push_back(*item);
      queue.Done();
    }
  });
  for (int i = 0; i < 50; ++i) ASSERT_TRUE(queue.Push(i));
  queue.WaitIdle();
  // Everything pushed was worked on before WaitIdle returned.
  EXPECT_EQ(done.size(), 50u);
  queue.Stop();
  consumer.join();
}

}  // namespace
}  // namespace lcv::slam
