// Integration: the whole engine (initialization, tracking, local mapping, local BA) on a
// synthetic feature sequence with known ground truth, in deterministic mode; and on a short
// stretch of KITTI 00 when the shared data is present.
#include "slam/system.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "mapping/eval/trajectory_error.h"
#include "mapping/io/trajectory.h"
#include "tests/slam/system/synthetic_features.h"

namespace lcv::slam {
namespace {

struct SyntheticRun {
  int frames = 0;
  int tracked = 0;
  int first_tracked = -1;
  double path_length = 0.0;
  std::vector<TimedPose> trajectory;
  mapping::TrajectoryErrorReport ape;
  int keyframes = 0;
  int landmarks = 0;
};

// configure: changes to the default options (null: none).
// on_result: called with each frame's result; stats_out: the engine's stats after Finish.
SyntheticRun RunSynthetic(std::uint64_t seed, int num_frames, bool deterministic = true,
                          const std::function<void(SystemOptions*)>& configure = nullptr,
                          const std::function<void(const FrameResult&)>& on_result = nullptr,
                          SystemStats* stats_out = nullptr) {
  const CameraParams params = testing::SyntheticPinhole();
  const std::unique_ptr<Camera> camera = MakeCamera(params);
  const testing::SyntheticScene scene =
      testing::MakeSlabScene(4000, -4.0, 0.1 * num_frames + 4.0, 4.0, 9.0, seed);
  const std::vector<Rigid3d> truth = testing::MakeLateralTrajectory(num_frames, 0.1);
  SystemOptions options;
  options.deterministic = deterministic;
  options.seed = seed;
  if (configure) configure(&options);
  System system(params, options);
  std::mt19937_64 rng(seed + 1);
  SyntheticRun run;
  run.frames = num_frames;
  mapping::Trajectory gt;
  for (int i = 0; i < num_frames; ++i) {
    testing::SyntheticFrame frame =
        testing::ObserveScene(scene, *camera, truth[i], testing::ObservationNoise(), &rng);
    const double timestamp = 0.1 * i;
    const FrameResult result =
        system.TrackFeatures(std::move(frame.keypoints), std::move(frame.descriptors), timestamp);
    gt.poses.push_back({timestamp, truth[i]});
    if (std::getenv("LCV_TEST_VERBOSE")) {
      std::fprintf(stderr, "frame %d: %s, %d keypoints, %d matches%s\n", i,
                   TrackingStateName(result.state), result.num_keypoints, result.num_matches,
                   result.is_keyframe ? ", keyframe" : "");
    }
    if (on_result) on_result(result);
    if (result.state == TrackingState::kTracking) {
      ++run.tracked;
      if (run.first_tracked < 0) run.first_tracked = i;
    }
    if (i > 0) run.path_length += (truth[i].Center() - truth[i - 1].Center()).norm();
  }
  system.Finish();
  if (stats_out != nullptr) *stats_out = system.Stats();
  run.trajectory = system.FrameTrajectory();
  run.keyframes = system.NumKeyframes();
  run.landmarks = system.NumLandmarks();
  mapping::TrajectoryErrorOptions ape_options;
  ape_options.alignment = mapping::TrajectoryAlignment::kSim3;
  run.ape = mapping::ComputeApe(gt, mapping::MakeTrajectory(run.trajectory), ape_options);
  return run;
}

TEST(SystemTest, SyntheticSequenceTracksWithSmallError) {
  const std::uint64_t seed = 7;
  const SyntheticRun run = RunSynthetic(seed, 60);
  SCOPED_TRACE("seed " + std::to_string(seed));
  ASSERT_GE(run.first_tracked, 0) << "never initialized";
  EXPECT_LE(run.first_tracked, 5);
  const int after_init = run.frames - run.first_tracked;
  EXPECT_GE(run.tracked, 0.95 * after_init) << run.tracked << " of " << after_init;
  ASSERT_FALSE(run.ape.problem) << *run.ape.problem;
  EXPECT_GE(run.ape.matched, 0.9 * run.frames);
  EXPECT_LT(run.ape.translation.rmse, 0.01 * run.path_length)
      << "APE " << run.ape.translation.rmse << " m over " << run.path_length << " m";
  std::printf("synthetic: %d of %d frames tracked, APE (Sim3) RMSE %.4f m over %.2f m, %d keyframes, "
              "%d points\n", run.tracked, run.frames, run.ape.translation.rmse, run.path_length,
              run.keyframes, run.landmarks);
  EXPECT_GE(run.keyframes, 3);
  EXPECT_GT(run.landmarks, 200);
}

// An initialization that waits (here for 4 degrees of parallax) poses the frames it waited
// through once the map exists: the reference frame is the first keyframe, the frames between
// it and the initializing frame are tracked against the new map, so the trajectory starts at
// the first frame.
TEST(SystemTest, FramesBeforeInitializationArePosedRetroactively) {
  const SyntheticRun run = RunSynthetic(7, 30, true, [](SystemOptions* options) {
    options->initializer.two_view.parallax_threshold_deg = 4.0;
  });
  ASSERT_GE(run.first_tracked, 0) << "never initialized";
  EXPECT_GE(run.first_tracked, 3) << "the initialization did not wait: nothing to test";
  std::vector<int> posed(run.frames, 0);
  for (const TimedPose& pose : run.trajectory) {
    const int index = static_cast<int>(std::lround(pose.timestamp / 0.1));
    ASSERT_TRUE(index >= 0 && index < run.frames) << pose.timestamp;
    ++posed[index];
  }
  for (int i = 0; i < run.frames; ++i) EXPECT_EQ(posed[i], 1) << "frame " << i;
  ASSERT_FALSE(run.ape.problem) << *run.ape.problem;
  EXPECT_EQ(run.ape.matched, run.frames);
  EXPECT_LT(run.ape.translation.rmse, 0.01 * run.path_length)
      << "APE " << run.ape.translation.rmse << " m over " << run.path_length << " m";
}

// Frames of an earlier attempt (its reference replaced, here after 2 frames) are posed
// backwards from the initialization's reference.
TEST(SystemTest, FramesOfAnAbandonedInitializationAttemptArePosedBackwards) {
  const SyntheticRun run = RunSynthetic(7, 30, true, [](SystemOptions* options) {
    options->initializer.two_view.parallax_threshold_deg = 2.5;
    options->initializer.max_reference_age_frames = 2;
  });
  ASSERT_GE(run.first_tracked, 0) << "never initialized";
  std::vector<int> posed(run.frames, 0);
  for (const TimedPose& pose : run.trajectory) {
    const int index = static_cast<int>(std::lround(pose.timestamp / 0.1));
    ASSERT_TRUE(index >= 0 && index < run.frames) << pose.timestamp;
    ++posed[index];
  }
  for (int i = 0; i < run.frames; ++i) EXPECT_EQ(posed[i], 1) << "frame " << i;
  ASSERT_FALSE(run.ape.problem) << *run.ape.problem;
  EXPECT_LT(run.ape.translation.rmse, 0.01 * run.path_length)
      << "APE " << run.ape.translation.rmse << " m over " << run.path_length << " m";
}

// The mapping thread: results depend on thread timing, so only loose bounds.
TEST(SystemTest, ThreadedModeTracksTheSyntheticSequence) {
  const SyntheticRun run = RunSynthetic(9, 40, /*deterministic=*/false);
  ASSERT_GE(run.first_tracked, 0) << "never initialized";
  EXPECT_GE(run.tracked, 0.8 * (run.frames - run.first_tracked));
  ASSERT_FALSE(run.ape.problem) << *run.ape.problem;
  EXPECT_LT(run.ape.translation.rmse, 0.05 * run.path_length);
  EXPECT_GE(run.keyframes, 2);
}

// Live input (SystemOptions::live): tracking never waits for the mapping thread. Frames are fed
// as fast as tracking returns, so the initial map arrives frames after it was asked for and
// keyframes meet a busy mapper; whatever the timing, the frames seen meanwhile are posed against
// the new map (on a later frame, or at Finish), every keyframe in the map was reported as one,
// and the others were refused.
TEST(SystemTest, LiveModeDoesNotWaitForMappingAndPosesTheFramesItKept) {
  int reported_keyframes = 0;
  SystemStats stats;
  const SyntheticRun run =
      RunSynthetic(9, 40, /*deterministic=*/false, [](SystemOptions* options) { options->live = true; },
                   [&](const FrameResult& result) { reported_keyframes += result.is_keyframe; },
                   &stats);
  ASSERT_FALSE(run.ape.problem) << *run.ape.problem;
  EXPECT_GE(run.ape.matched, 0.8 * run.frames) << "frames kept while the map was built are posed";
  EXPECT_LT(run.ape.translation.rmse, 0.05 * run.path_length);
  EXPECT_GE(run.keyframes, 2);
  // Each keyframe of the map was accepted (culling only removes); the initial pair counts two
  // keyframes for one reported frame when the map arrived in time, none when it came later.
  EXPECT_LE(run.keyframes, reported_keyframes + 2);
  EXPECT_GT(stats.map_lock_mapping.count, 0) << "the mapping thread's holds are recorded";
  std::printf("live: %d keyframes reported, %d refused, %d in the map; tracking lock max %.3f ms\n",
              reported_keyframes, stats.keyframes_refused, run.keyframes,
              stats.map_lock_tracking.max_ms);
}

// The background threads run below tracking's priority (SystemOptions::background_nice,
// slam/util/thread_priority.h), and each frame says where its tracking time went.
TEST(SystemTest, BackgroundThreadsRunBelowTrackingAndFramesReportTheirStages) {
  SystemStats stats;
  int tracked_with_motion_stage = 0, tracked = 0;
  bool stages_within_tracking_time = true;
  const SyntheticRun run = RunSynthetic(
      9, 30, /*deterministic=*/false, [](SystemOptions* options) { options->background_nice = 7; },
      [&](const FrameResult& r) {
        const TrackingStageTimes& s = r.stages;
        const double stages = s.handover_ms + s.initializer_ms + s.initialization_frames_ms +
                              s.motion_ms + s.recovery_ms + s.relocalization_ms +
                              s.two_view_ms + s.local_map_ms + s.keyframe_decision_ms;
        // Parts of one span, read from one monotonic clock: they cannot exceed it.
        if (r.extraction_ms + stages > r.tracking_ms + 1e-6) stages_within_tracking_time = false;
        if (r.state == TrackingState::kTracking && !r.is_keyframe) {
          ++tracked;
          tracked_with_motion_stage += s.motion_ms > 0.0 && s.local_map_ms > 0.0;
        }
      },
      &stats);
  ASSERT_GE(run.first_tracked, 0) << "never initialized";
  EXPECT_TRUE(stages_within_tracking_time);
  EXPECT_GT(tracked, 0);
  EXPECT_EQ(tracked_with_motion_stage, tracked) << "a tracked frame ran the motion model and the local map";
#if defined(__linux__)
  EXPECT_TRUE(stats.thread_priority_error.empty()) << stats.thread_priority_error;
  EXPECT_EQ(stats.mapping_thread_nice, std::min(19, stats.tracking_thread_nice + 7));
#endif
  // Tracking takes the snapshot lock only when a new snapshot was published (and the writer
  // queue's lock to hand a keyframe over), not on every frame.
  EXPECT_GT(stats.map_lock_tracking.count, 0);
  EXPECT_LT(stats.map_lock_tracking.count, run.frames);
}

TEST(SystemTest, DeterministicModeIsReproducible) {
  const SyntheticRun a = RunSynthetic(11, 30);
  const SyntheticRun b = RunSynthetic(11, 30);
  ASSERT_EQ(a.trajectory.size(), b.trajectory.size());
  ASSERT_GT(a.trajectory.size(), 10u);
  for (size_t i = 0; i < a.trajectory.size(); ++i) {
    EXPECT_EQ(a.trajectory[i].cam_from_world.translation, b.trajectory[i].cam_from_world.translation);
    EXPECT_EQ(a.trajectory[i].cam_from_world.rotation.coeffs(),
              b.trajectory[i].cam_from_world.rotation.coeffs());
  }
}

TEST(SystemTest, ExportedMapIsConsistent) {
  const CameraParams params = testing::SyntheticPinhole();
  const std::unique_ptr<Camera> camera = MakeCamera(params);
  const testing::SyntheticScene scene = testing::MakeSlabScene(3000, -4.0, 6.0, 4.0, 9.0, 3);
  const std::vector<Rigid3d> truth = testing::MakeLateralTrajectory(20, 0.1);
  SystemOptions options;
  options.deterministic = true;
  System system(params, options);
  std::mt19937_64 rng(4);
  for (int i = 0; i < 20; ++i) {
    testing::SyntheticFrame f =
        testing::ObserveScene(scene, *camera, truth[i], testing::ObservationNoise(), &rng);
    system.TrackFeatures(std::move(f.keypoints), std::move(f.descriptors), 0.1 * i);
  }
  system.Finish();
  const Map map = system.ExportMap();
  ASSERT_EQ(map.cameras.size(), 1u);
  EXPECT_EQ(static_cast<int>(map.keyframes.size()), system.NumKeyframes());
  EXPECT_GT(map.points.size(), 100u);
  for (const auto& [id, point] : map.points) {
    EXPECT_GE(point.observations.size(), 2u) << "point " << id;
    for (const Observation& o : point.observations) {
      ASSERT_TRUE(map.keyframes.count(o.keyframe_id)) << "point " << id;
      EXPECT_LT(o.keypoint_index, map.keyframes.at(o.keyframe_id).keypoints.size());
    }
  }
  EXPECT_GE(map.NextFreeId(), 1u);
}

// A short stretch of real KITTI images through the ORB front end. Deterministic mode: under
// `ctest -j` on two cores the mapping thread's share of the CPU varies, and this test checks the
// front end on real images, not the threading (ThreadedModeTracksTheSyntheticSequence does).
TEST(SystemTest, KittiStretchIsTracked) {
  const std::string dir = std::string(LCV_SHARED_DIR) + "/data/kitti00";
  if (!std::filesystem::exists(dir + "/image_0/000000.png")) {
    GTEST_SKIP() << "shared KITTI data absent: " << dir;
  }
  CameraParams params;
  params.model = CameraModel::kPerspective;
  params.cols = 1241;
  params.rows = 376;
  params.fx = params.fy = 718.856;
  params.cx = 607.1928;
  params.cy = 185.2157;
  params.fps = 10;
  SystemOptions options;
  options.deterministic = true;
  System system(params, options);
  const std::vector<double> times = mapping::ReadTimesFile(dir + "/times.txt");
  mapping::Trajectory gt = mapping::ReadTrajectory(dir + "/poses.txt", mapping::TrajectoryFormat::kKitti);
  mapping::AssignTimestamps(times, dir + "/times.txt", &gt);
  const int num_frames = 40;
  int tracked = 0;
  int first_tracked = -1;
  for (int i = 0; i < num_frames; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "/image_0/%06d.png", i);
    const cv::Mat image = cv::imread(dir + name, cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(image.empty()) << dir + name;
    const FrameResult r = system.TrackImage(image, times[i]);
    if (r.state == TrackingState::kTracking) {
      ++tracked;
      if (first_tracked < 0) first_tracked = i;
    }
  }
  system.Finish();
  ASSERT_GE(first_tracked, 0) << "never initialized";
  EXPECT_GE(tracked, 0.9 * (num_frames - first_tracked));
  mapping::TrajectoryErrorOptions ape_options;
  ape_options.alignment = mapping::TrajectoryAlignment::kSim3;
  const auto ape = mapping::ComputeApe(gt, mapping::MakeTrajectory(system.FrameTrajectory()), ape_options);
  ASSERT_FALSE(ape.problem) << *ape.problem;
  // About 28 m of motion in 40 frames.
  EXPECT_LT(ape.translation.rmse, 0.5) << "APE RMSE " << ape.translation.rmse;
}

TEST(SystemTest, DefaultFeatureBudgetFollowsImageSizeAndModel) {
  EXPECT_EQ(DefaultNumFeatures(CameraModel::kPerspective, 1241, 376), 2000);  // ORB-SLAM's KITTI
  EXPECT_EQ(DefaultNumFeatures(CameraModel::kPerspective, 640, 360), 1000);
  EXPECT_EQ(DefaultNumFeatures(CameraModel::kFisheye, 640, 360), 1000);
  EXPECT_EQ(DefaultNumFeatures(CameraModel::kPerspective, 4000, 3000), 2000);
  // The sphere is spread over the image: twice the perspective budget of the same size.
  EXPECT_EQ(DefaultNumFeatures(CameraModel::kEquirectangular, 640, 320), 2000);
  EXPECT_EQ(DefaultNumFeatures(CameraModel::kEquirectangular, 1920, 960), 4000);
  EXPECT_EQ(DefaultNumFeatures(CameraModel::kPerspective, 800, 400), 1372);  // 2000 x 320k / 467k
  EXPECT_EQ(DefaultNumFeatures(CameraModel::kEquirectangular, 800, 400), 2743);
}

}  // namespace
}  // namespace lcv::slam
