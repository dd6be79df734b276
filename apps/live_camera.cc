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
  struct NormalSchedulingAtExit {
    bool active;
    ~NormalSchedulingAtExit() {
      if (active) slam::UseNormalScheduling();
    }
  } restore{run.tracking_rt_priority > 0};
  try {
    while (std::optional<CameraImage> frame = slot.Pop()) {
      track(frame->index, frame->image);
      slot.Done();
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
