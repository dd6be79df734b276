// Integration: tracking through a sharp street corner. The first 20 client frames of the
// synthetic `loop` scenario rendered at 100 frames per lap (render/synth_scenario.h) drive
// 2.7 m per frame and turn the first corner in four frames (22, 29, 26 and 6 degrees, frames
// 8-11): the constant-velocity prediction is wrong by a whole frame's turn where the turn
// starts and stops, and the next street is hardly in the map when the camera turns into it.
// The engine (deterministic mode, ORB front end, no vocabulary: no relocalization to fall back
// on) must track every frame after the initialization with one initialization (no reset),
// for the perspective and the fisheye camera. Before the tracker inserted a keyframe when its
// motion model failed and matched the last frame without a prediction, both lost the corner
// at frame 9 and re-initialized (docs/slam.md "Sharp turns").
// The second corner (frames 26-30: 26, 30 and 24 degrees) is harder for the perspective camera:
// frame 29 sees a handful of map points at its true pose, and only the two-view step (the pose
// from 2D-2D matches to frame 28, slam/tracking_two_view.cc) follows it. Without that step
// (TrackingSettings::two_view_recovery off, as before it existed) the map is reset there.
#include <cstdio>
#include <cstdlib>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "mapping/eval/trajectory_error.h"
#include "mapping/io/trajectory.h"
#include "render/scene_renderer.h"
#include "render/synth_scenario.h"
#include "slam/system.h"

namespace lcv::slam {
namespace {

constexpr int kLapFrames = 100;  // frames per lap: 2.7 m per frame
constexpr int kFrames = 20;      // the first corner is at frames 8-11
constexpr int kSecondCornerFrames = 36;  // the second one at frames 26-30
constexpr int kCols = 640, kRows = 360;
constexpr double kFps = 10.0;

struct CornerRun {
  int tracked_after_initialization = 0;
  int first_tracked = -1;
  int initializations = 0;
  int two_view_poses = 0;
  double path_length_m = 0.0;
  mapping::TrajectoryErrorReport ape;
};

CornerRun RunCorner(CameraModel model, int num_frames = kFrames, bool two_view_recovery = true) {
  const render::Scenario scenario = render::MakeScenario("loop", kLapFrames, 1);
  const CameraParams camera = render::SynthCamera(model, kCols, kRows, kFps);
  render::SceneRenderer renderer(scenario.scene);
  SystemOptions options;
  options.deterministic = true;
  options.features.num_features = DefaultNumFeatures(model, kCols, kRows);
  options.tracking.two_view_recovery = two_view_recovery;
  System system(camera, options);
  CornerRun run;
  mapping::Trajectory ground_truth;
  for (int i = 0; i < num_frames; ++i) {
    const Rigid3d& truth = scenario.client_cam_from_world[i];
    cv::Mat gray;
    cv::cvtColor(renderer.Render(camera, truth, render::SequenceKind::kClient), gray,
                 cv::COLOR_BGR2GRAY);
    const FrameResult r = system.TrackImage(gray, i / kFps);
    ground_truth.poses.push_back({i / kFps, truth});
    if (i > 0) {
      run.path_length_m +=
          (truth.Center() - scenario.client_cam_from_world[i - 1].Center()).norm();
    }
    if (r.state == TrackingState::kTracking) {
      if (run.first_tracked < 0) run.first_tracked = i;
      ++run.tracked_after_initialization;
    }
    run.two_view_poses += r.two_view;
    if (std::getenv("LCV_TEST_VERBOSE")) {
      std::fprintf(stderr, "%d %s %d%s%s%s\n", i, TrackingStateName(r.state), r.num_matches,
                   r.is_keyframe ? " kf" : "", r.relocalized ? " reloc" : "",
                   r.two_view ? " two-view" : "");
    }
  }
  system.Finish();
  run.initializations = system.NumInitializations();
  mapping::TrajectoryErrorOptions ape_options;
  ape_options.alignment = mapping::TrajectoryAlignment::kSim3;
  run.ape = mapping::ComputeApe(ground_truth, mapping::MakeTrajectory(system.FrameTrajectory()),
                                ape_options);
  return run;
}

CornerRun ExpectCornerTracked(CameraModel model, int num_frames = kFrames) {
  const CornerRun run = RunCorner(model, num_frames);
  EXPECT_GE(run.first_tracked, 0) << "never initialized";
  if (run.first_tracked < 0) return run;
  EXPECT_EQ(run.initializations, 1) << "the map was reset";
  EXPECT_EQ(run.tracked_after_initialization, num_frames - run.first_tracked);
  EXPECT_FALSE(run.ape.problem) << *run.ape.problem;
  if (run.ape.problem) return run;
  EXPECT_EQ(run.ape.matched, num_frames);
  // Measured 0.15 m (perspective and fisheye) over 51 m: a pose lost in the turn and
  // guessed would be metres off.
  EXPECT_LT(run.ape.translation.rmse, 0.02 * run.path_length_m)
      << "APE " << run.ape.translation.rmse << " m over " << run.path_length_m << " m";
  std::printf("sharp turn: %d of %d frames tracked (%d two-view), APE (Sim3) %.4f m over %.1f m\n",
              run.tracked_after_initialization, num_frames, run.two_view_poses,
              run.ape.translation.rmse, run.path_length_m);
  return run;
}

TEST(SharpTurnTest, PerspectiveCameraTracksTheCornerWithoutReset) {
  ExpectCornerTracked(CameraModel::kPerspective);
}

TEST(SharpTurnTest, FisheyeCameraTracksTheCornerWithoutReset) {
  ExpectCornerTracked(CameraModel::kFisheye);
}

TEST(SharpTurnTest, PerspectiveCameraTracksTheSecondCornerByTwoView) {
  const CornerRun run = ExpectCornerTracked(CameraModel::kPerspective, kSecondCornerFrames);
  EXPECT_GE(run.two_view_poses, 1) << "the corner was followed without the two-view step";
  // Without it the frame after the corner's sharpest turn is lost and, with no vocabulary to
  // relocalize with, the map is reset: the step is what keeps the map.
  const CornerRun without = RunCorner(CameraModel::kPerspective, kSecondCornerFrames,
                                      /*two_view_recovery=*/false);
  EXPECT_GT(without.initializations, 1);
  EXPECT_EQ(without.two_view_poses, 0);
}

}  // namespace
}  // namespace lcv::slam
