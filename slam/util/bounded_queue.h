#pragma once
// A bounded multi-producer work queue between the engine's threads (STYLE.md 5; after COLMAP's
// util/threading.h JobQueue). Never grows past its capacity; the producer chooses what a full
// queue means:
//   Push            waits for room (offline input: the producer can be paused),
//   TryPush         refuses (live keyframes: tracking must not wait, the candidate is dropped),
//   PushDropOldest  replaces the oldest item (live frames: a camera keeps the newest image).
// The consumer Pops an item, works on it, and calls Done(); WaitIdle() returns when the queue is
// empty and no popped item is still being worked on (a drain). Stop() wakes everyone: pushes
// fail from then on, Pop returns the items left and then nullopt.
//
// Thread safety: every member may be called from any thread. The internal mutex is held only
// for the container operation (never while the item is worked on); an optional recorder gets
// each hold time (slam/util/lock_timing.h). Items are moved, never copied.

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <mutex>
#include <optional>
#include <utility>

#include "slam/util/lock_timing.h"

namespace lcv::slam {

template <typename T>
class BoundedQueue {
 public:
  // capacity >= 1.
  explicit BoundedQueue(std::size_t capacity) : capacity_(capacity < 1 ? 1 : capacity) {}

  // Waits while the queue is full. False (item dropped) once stopped.
  bool Push(T item, LockHoldRecorder* recorder = nullptr) {
    std::unique_lock<std::mutex> lock(mutex_);
    space_.wait(lock, [&] { return stopped_ || items_.size() < capacity_; });
    const auto held = std::chrono::steady_clock::now();
    if (stopped_) return false;
    items_.push_back(std::move(item));
    Record(recorder, held);
    lock.unlock();
    ready_.notify_one();
    return true;
  }

  // Takes the item only when there is room; false (item untouched) when full or stopped.
  bool TryPush(T&& item, LockHoldRecorder* recorder = nullptr) {
    {
      TimedLock lock(mutex_, recorder);
      if (stopped_ || items_.size() >= capacity_) return false;
      items_.push_back(std::move(item));
    }
    ready_.notify_one();
    return true;
  }

  // Always takes the item; when full, the oldest item is discarded first. Returns how many
  // items were discarded (0 or 1; the item itself when stopped).
  int PushDropOldest(T item, LockHoldRecorder* recorder = nullptr) {
    int dropped = 0;
    {
      TimedLock lock(mutex_, recorder);
      if (stopped_) return 1;
      if (items_.size() >= capacity_) {
        items_.pop_front();
        dropped = 1;
      }
      items_.push_back(std::move(item));
    }
    ready_.notify_one();
    return dropped;
  }

  // Waits for an item; nullopt once stopped and empty. The consumer calls Done() after working
  // on a popped item.
  std::optional<T> Pop(LockHoldRecorder* recorder = nullptr) {
    std::unique_lock<std::mutex> lock(mutex_);
    ready_.wait(lock, [&] { return stopped_ || !items_.empty(); });
    const auto held = std::chrono::steady_clock::now();
    if (items_.empty()) return std::nullopt;
    std::optional<T> item(std::move(items_.front()));
    items_.pop_front();
    ++in_flight_;
    Record(recorder, held);
    lock.unlock();
    space_.notify_all();
    return item;
  }

  // Like Pop without waiting: nullopt when empty.
  std::optional<T> TryPop(LockHoldRecorder* recorder = nullptr) {
    std::optional<T> item;
    {
      TimedLock lock(mutex_, recorder);
      if (items_.empty()) return std::nullopt;
      item.emplace(std::move(items_.front()));
      items_.pop_front();
      ++in_flight_;
    }
    space_.notify_all();
    return item;
  }

  // The consumer finished an item it popped.
  void Done(LockHoldRecorder* recorder = nullptr) {
    {
      TimedLock lock(mutex_, recorder);
      if (in_flight_ > 0) --in_flight_;
    }
    idle_.notify_all();
  }

  // Waits until the queue is empty and no popped item is in flight (or the queue is stopped).
  void WaitIdle() {
    std::unique_lock<std::mutex> lock(mutex_);
    idle_.wait(lock, [&] { return stopped_ || (items_.empty() && in_flight_ == 0); });
  }

  void Stop() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopped_ = true;
    }
    ready_.notify_all();
    space_.notify_all();
    idle_.notify_all();
  }

  std::size_t size() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return items_.size();
  }
  // No item waiting and none in flight.
  bool Idle() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return items_.empty() && in_flight_ == 0;
  }
  bool Full() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return items_.size() >= capacity_;
  }
  std::size_t capacity() const { return capacity_; }

 private:
  static void Record(LockHoldRecorder* recorder, std::chrono::steady_clock::time_point held) {
    if (recorder == nullptr) return;
    recorder->Add(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - held)
            .count());
  }

  const std::size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable ready_;  // an item arrived (or stop)
  std::condition_variable space_;  // an item left (or stop)
  std::condition_variable idle_;   // an item was done (or stop)
  std::deque<T> items_;
  int in_flight_ = 0;
  bool stopped_ = false;
};

}  // namespace lcv::slam
