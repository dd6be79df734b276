#pragma once
// The task queue of the map's one writer (System's mapping thread, docs/slam.md "Threads"):
// keyframe candidates from tracking and other tasks (initialization, reset, relocalization,
// loop corrections, global BA results), run in the order they were queued, so that a reset
// queued after a keyframe comes after it.
//
// Keyframes are bounded: at most keyframe_capacity wait. PushKeyframe either waits for room
// (offline input) or refuses the keyframe (live input: tracking must not wait). Other tasks are
// not counted: their producers keep at most one of each kind outstanding (System), which bounds
// them.
//
// Thread safety: every member may be called from any thread; the mutex is held only for the
// container operation (never while a task runs). Idle() and HasKeyframeRoom(), asked by
// tracking on every frame, take no lock: they read counters written under it (an answer a
// moment old, as one read under the lock could be by the time it is used). Recorders
// (slam/util/lock_timing.h) belong to the calling thread.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <list>
#include <mutex>
#include <optional>
#include <utility>

#include "slam/data/frame.h"
#include "slam/util/lock_timing.h"

namespace lcv::slam {

class MapWriterQueue {
 public:
  struct Task {
    std::optional<Frame> keyframe;  // a keyframe candidate to map, or
    std::function<void()> work;     // anything else the writer does
  };

  // keyframe_capacity >= 1 (smaller values are taken as 1).
  explicit MapWriterQueue(int keyframe_capacity)
      : keyframe_capacity_(keyframe_capacity < 1 ? 1 : keyframe_capacity) {}

  // Queues a keyframe. wait: block while keyframe_capacity keyframes wait; otherwise refuse.
  // False when refused (full without wait, or stopped); frame is then left as it was.
  // The task's list node is made before the lock and spliced in under it: the hold is a few
  // pointer moves (no allocation), so that a preemption of the caller is unlikely to fall in it.
  bool PushKeyframe(Frame&& frame, bool wait, LockHoldRecorder* recorder = nullptr) {
    if (!wait && keyframes_queued_.load() >= keyframe_capacity_) return false;  // no lock
    std::list<Task> node;
    node.push_back(Task{std::move(frame), nullptr});
    std::unique_lock<std::mutex> lock(mutex_);
    if (wait) {
      space_.wait(lock, [&] { return stopped_ || keyframes_queued_ < keyframe_capacity_; });
    }
    const auto held = std::chrono::steady_clock::now();
    const bool refused = stopped_ || keyframes_queued_ >= keyframe_capacity_;
    if (!refused) {
      tasks_.splice(tasks_.end(), node);
      keyframes_queued_.fetch_add(1);
    }
    Unlock(&lock, recorder, held);
    if (refused) {
      frame = std::move(*node.front().keyframe);
      return false;
    }
    ready_.notify_one();
    return true;
  }

  // Queues another task. False (not queued) once stopped.
  bool PushTask(std::function<void()> work, LockHoldRecorder* recorder = nullptr) {
    std::list<Task> node;
    node.push_back(Task{std::nullopt, std::move(work)});
    {
      TimedLock lock(mutex_, recorder);
      if (stopped_) return false;
      tasks_.splice(tasks_.end(), node);
    }
    ready_.notify_one();
    return true;
  }

  // The writer: waits for the next task; nullopt once stopped and empty. Call Done() after
  // running it.
  std::optional<Task> Pop(LockHoldRecorder* recorder = nullptr) {
    std::unique_lock<std::mutex> lock(mutex_);
    ready_.wait(lock, [&] { return stopped_ || !tasks_.empty(); });
    const auto held = std::chrono::steady_clock::now();
    if (tasks_.empty()) return std::nullopt;
    // The node leaves the queue under the lock and is freed after it.
    std::list<Task> node;
    node.splice(node.end(), tasks_, tasks_.begin());
    const bool keyframe = node.front().keyframe.has_value();
    if (keyframe) keyframes_queued_.fetch_sub(1);
    busy_ = true;
    busy_with_keyframe_ = keyframe;
    Unlock(&lock, recorder, held);
    space_.notify_all();
    return std::optional<Task>(std::move(node.front()));
  }

  void Done(LockHoldRecorder* recorder = nullptr) {
    {
      TimedLock lock(mutex_, recorder);
      busy_ = false;
      busy_with_keyframe_ = false;
    }
    space_.notify_all();
  }

  // Waits until every queued keyframe has been mapped (other tasks may still wait or run), or
  // the queue is stopped.
  void WaitKeyframesMapped() {
    std::unique_lock<std::mutex> lock(mutex_);
    space_.wait(lock, [&] { return stopped_ || (keyframes_queued_ == 0 && !busy_with_keyframe_); });
  }

  // No keyframe waiting and the writer not busy: a keyframe now would be mapped at once (the
  // keyframe policy's "mapping idle"). Lock-free (see the top).
  bool Idle() const { return keyframes_queued_.load() == 0 && !busy_.load(); }
  // A keyframe pushed now would be queued without waiting. Lock-free.
  bool HasKeyframeRoom() const { return keyframes_queued_.load() < keyframe_capacity_; }
  int keyframes_queued() const { return keyframes_queued_.load(); }

  // Waits until every queued task has run (or the queue is stopped).
  void WaitIdle() {
    std::unique_lock<std::mutex> lock(mutex_);
    space_.wait(lock, [&] { return stopped_ || (tasks_.empty() && !busy_); });
  }

  // Pushes fail from now on; Pop returns the tasks left, then nullopt.
  void Stop() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopped_ = true;
    }
    ready_.notify_all();
    space_.notify_all();
  }

 private:
  // Releases the lock, then records how long it was held (the recorder's bookkeeping is not
  // part of the hold).
  static void Unlock(std::unique_lock<std::mutex>* lock, LockHoldRecorder* recorder,
                     std::chrono::steady_clock::time_point held) {
    const auto released = std::chrono::steady_clock::now();
    lock->unlock();
    if (recorder == nullptr) return;
    recorder->Add(std::chrono::duration<double, std::milli>(released - held).count());
  }

  const int keyframe_capacity_;
  mutable std::mutex mutex_;
  std::condition_variable ready_;  // a task arrived (or stop)
  std::condition_variable space_;  // a task left or finished (or stop)
  std::list<Task> tasks_;  // a list: nodes are made and freed outside the lock
  // Written under mutex_ (so that the condition variables' predicates see them), read without
  // it by Idle() / HasKeyframeRoom().
  std::atomic<int> keyframes_queued_{0};
  std::atomic<bool> busy_{false};
  bool busy_with_keyframe_ = false;
  bool stopped_ = false;
};

}  // namespace lcv::slam
