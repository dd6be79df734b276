// `lcv slam --realtime`'s camera stand-in (apps/live_camera.h): every image is either tracked or
// dropped, and tracking's real-time scheduling holds only while it keeps up. Behaviour only, no
// timed assertions: a tracker that sleeps three camera periods per frame is behind by
// construction, one that returns at once is not.
#include "apps/live_camera.h"

#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "mapping/io/dataset.h"
#include "slam/util/thread_priority.h"

namespace lcv::apps {
namespace {

namespace fs = std::filesystem;

// A KITTI-layout sequence of n small images at 50 Hz.
std::unique_ptr<mapping::Dataset> MakeSequence(const fs::path& dir, int n) {
  fs::create_directories(dir / "image_0");
  std::ofstream times(dir / "times.txt");
  for (int i = 0; i < n; ++i) {
    char name[16];
    std::snprintf(name, sizeof(name), "%06d.png", i);
    EXPECT_TRUE(cv::imwrite((dir / "image_0" / name).string(),
                            cv::Mat(24, 32, CV_8UC1, cv::Scalar(5 * i))));
    times << 0.02 * i << "\n";
  }
  times.close();
  std::ofstream(dir / "calib.txt") << "P0: 3.0e+01 0 1.55e+01 0 0 3.1e+01 1.15e+01 0 0 0 1 0\n";
  return mapping::OpenDataset(dir.string());
}

fs::path TempDir(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("lcv_live_camera_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  return dir;
}

TEST(LiveCamera, TrackingThatKeepsUpRunsUnderItsRealtimePriority) {
  const fs::path dir = TempDir("fast");
  const auto dataset = MakeSequence(dir, 12);
  int tracked = 0, priority_seen = -1;
  LiveCameraOptions options;
  options.tracking_rt_priority = 5;
  const LiveCameraRun run = RunLiveCamera(
      *dataset,
      [&](size_t, const cv::Mat& image) {
        EXPECT_FALSE(image.empty());
        if (tracked++ == 0) priority_seen = slam::CurrentThreadRealtimePriority();
      },
      options);
  EXPECT_EQ(tracked + run.frames_dropped, 12);
  EXPECT_EQ(slam::CurrentThreadRealtimePriority(), 0) << "normal scheduling after the camera";
  if (run.tracking_rt_priority == 0) {  // the system refused: said, and nothing changed
    EXPECT_NE(run.priority_error, "");
    EXPECT_EQ(priority_seen, 0);
  } else {
    EXPECT_EQ(run.tracking_rt_priority, 5);
    EXPECT_EQ(priority_seen, 5);
  }
  fs::remove_all(dir);
}

TEST(LiveCamera, TrackingThatFallsBehindLeavesRealtimeScheduling) {
  const fs::path dir = TempDir("slow");
  const auto dataset = MakeSequence(dir, 15);
  int tracked = 0;
  int priority_at_last_frame = -1;
  LiveCameraOptions options;
  options.tracking_rt_priority = 5;
  const LiveCameraRun run = RunLiveCamera(
      *dataset,
      [&](size_t, const cv::Mat&) {
        ++tracked;
        priority_at_last_frame = slam::CurrentThreadRealtimePriority();
        std::this_thread::sleep_for(std::chrono::milliseconds(60));  // 3 camera periods
      },
      options);
  EXPECT_GT(run.frames_dropped, 0);
  EXPECT_EQ(tracked + run.frames_dropped, 15);
  EXPECT_EQ(slam::CurrentThreadRealtimePriority(), 0);
  if (run.tracking_rt_priority > 0) {
    EXPECT_GE(run.realtime_suspensions, 1);
    EXPECT_EQ(priority_at_last_frame, 0) << "behind since the first frames: never given back";
  } else {
    EXPECT_EQ(run.realtime_suspensions, 0);
  }
  fs::remove_all(dir);
}

TEST(LiveCamera, WithoutARealtimePriorityNothingChanges) {
  const fs::path dir = TempDir("none");
  const auto dataset = MakeSequence(dir, 5);
  int tracked = 0;
  const LiveCameraRun run = RunLiveCamera(
      *dataset,
      [&](size_t, const cv::Mat&) {
        ++tracked;
        EXPECT_EQ(slam::CurrentThreadRealtimePriority(), 0);
      });
  EXPECT_EQ(run.tracking_rt_priority, 0);
  EXPECT_EQ(run.priority_error, "");
  EXPECT_EQ(tracked + run.frames_dropped, 5);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace lcv::apps
