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
constexpr int kCols = 640, kRows = 360;
constexpr double kFps = 10.0;

struct CornerRun {
  int tracked_after_initialization = 0;
  int first_tracked = -1;
  int initializations = 0;
  double path_length_m = 0.0;
  mapping::TrajectoryErrorReport ape;
};

CornerRun RunCorner(CameraModel model) {
  const render::Scenario scenario = render::MakeScenario("loop", kLapFrames, 1);
  const CameraParams camera = render::SynthCamera(model, kCols, kRows, kFps);
  render::SceneRenderer renderer(scenario.scene);
  SystemOptions options;
  options.deterministic = true;
  options.features.num_features = DefaultNumFeatures(model, kCols, kRows);
  System system(camera, options);
  CornerRun run;
  mapping::Trajectory ground_truth;
  for (int i = 0; i < kFrames; ++i) {
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
    if (std::getenv("LCV_TEST_VERBOSE")) {
      std::fprintf(stderr, "%d %s %d%s%s\n", i, TrackingStateName(r.state), r.num_matches,
                   r.is_keyframe ? " kf" : "", r.relocalized ? " reloc" : "");
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

void ExpectCornerTracked(CameraModel model) {
  const CornerRun run = RunCorner(model);
  ASSERT_GE(run.first_tracked, 0) << "never initialized";
  EXPECT_EQ(run.initializations, 1) << "the map was reset";
  EXPECT_EQ(run.tracked_after_initialization, kFrames - run.first_tracked);
  ASSERT_FALSE(run.ape.problem) << *run.ape.problem;
  EXPECT_EQ(run.ape.matched, kFrames);
  // Measured 0.15 m (perspective and fisheye) over 51 m: a pose lost in the turn and
  // guessed would be metres off.
  EXPECT_LT(run.ape.translation.rmse, 0.02 * run.path_length_m)
      << "APE " << run.ape.translation.rmse << " m over " << run.path_length_m << " m";
  std::printf("sharp turn: %d of %d frames tracked, APE (Sim3) %.4f m over %.1f m\n",
              run.tracked_after_initialization, kFrames, run.ape.translation.rmse,
              run.path_length_m);
}

TEST(SharpTurnTest, PerspectiveCameraTracksTheCornerWithoutReset) {
  ExpectCornerTracked(CameraModel::kPerspective);
}

TEST(SharpTurnTest, FisheyeCameraTracksTheCornerWithoutReset) {
  ExpectCornerTracked(CameraModel::kFisheye);
}

}  // namespace
}  // namespace lcv::slam
