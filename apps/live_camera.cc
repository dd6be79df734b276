#include "apps/live_camera.h"

#include <atomic>
#include <chrono>
#include <exception>
#include <optional>
#include <thread>

#include "slam/util/bounded_queue.h"
#include "slam/util/thread_priority.h"

namespace lcv::apps {

LiveCameraRun RunLiveCamera(const mapping::Dataset& dataset,
                            const std::function<void(size_t, const cv::Mat&)>& track,
                            const LiveCameraOptions& options) {
  struct CameraImage {
    size_t index = 0;
    cv::Mat image;
  };
  slam::BoundedQueue<CameraImage> slot(1);
  std::atomic<int> dropped{0};
  std::exception_ptr camera_error;
  std::thread camera([&] {
    // Best effort: a camera at the caller's priority still works, only with more jitter.
    slam::LowerCurrentThreadPriority(options.camera_nice);
    try {
      const auto start = std::chrono::steady_clock::now();
      for (size_t i = 0; i < dataset.size(); ++i) {
        CameraImage frame{i, dataset.LoadImage(i, true)};
        const double due_s = dataset.frames()[i].timestamp - dataset.frames()[0].timestamp;
        std::this_thread::sleep_until(
            start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                        std::chrono::duration<double>(due_s)));
        dropped += slot.PushDropOldest(std::move(frame));
      }
    } catch (...) {
      camera_error = std::current_exception();
    }
    slot.Stop();
  });
  // After the camera thread exists, so that it does not inherit the policy.
  LiveCameraRun run;
  if (options.tracking_rt_priority > 0 &&
      slam::UseRealtimeScheduling(options.tracking_rt_priority, &run.priority_error)) {
    run.tracking_rt_priority = options.tracking_rt_priority;
  }
  // Real-time scheduling only while tracking keeps up. A tracking thread that is always behind
  // the camera never blocks, and under SCHED_FIFO it would keep its core from every other
  // thread for good (a machine too slow for the camera, a sanitizer build: mapping then
  // refuses keyframe after keyframe). A frame dropped while tracking returns it to normal
  // scheduling; kKeepUpFrames frames in a row without a drop give the priority back.
  constexpr int kKeepUpFrames = 10;
  bool realtime_now = run.tracking_rt_priority > 0;
  struct NormalSchedulingAtExit {
    const bool* active;
    ~NormalSchedulingAtExit() {
      if (*active) slam::UseNormalScheduling();
    }
  } restore{&realtime_now};
  int dropped_before = 0;
  int frames_kept_up = 0;
  try {
    while (std::optional<CameraImage> frame = slot.Pop()) {
      track(frame->index, frame->image);
      slot.Done();
      if (run.tracking_rt_priority == 0) continue;
      const int dropped_now = dropped.load();
      if (dropped_now != dropped_before) {
        frames_kept_up = 0;
        if (realtime_now && slam::UseNormalScheduling()) {
          realtime_now = false;
          ++run.realtime_suspensions;
        }
      } else if (!realtime_now && ++frames_kept_up >= kKeepUpFrames) {
        realtime_now = slam::UseRealtimeScheduling(options.tracking_rt_priority);
      }
      dropped_before = dropped_now;
    }
  } catch (...) {
    slot.Stop();
    camera.join();
    throw;
  }
  camera.join();
  if (camera_error) std::rethrow_exception(camera_error);
  run.frames_dropped = dropped.load();
  return run;
}

}  // namespace lcv::apps
