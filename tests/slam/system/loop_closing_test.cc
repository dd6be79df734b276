// Integration: loop closing on a rendered loop. The client sequence of the synthetic `loop`
// scenario (render/synth_scenario.h) drives once around a city block and back into its start;
// monocular tracking alone drifts by tens of metres at this small size (320x180), so the revisit
// is far from the start in the estimate. The engine (deterministic mode, images through the ORB
// front end) runs twice, with and without loop closing, and must detect the loop against the
// start, close it, and end with a clearly lower APE (the target: >= 30% lower).
//
// The vocabulary is trained in the test on renders of another seed of the scenario (other
// textures and building layout), small (10^4 words): the test is about the engine's use of
// place recognition; the shipped vocabulary is tested in tests/slam/bow and measured by
// bench/bench_loop_closing.
#include <algorithm>
#include <cstdlib>
#include <cstdio>
#include <memory>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "mapping/eval/trajectory_error.h"
#include "mapping/io/trajectory.h"
#include "render/scene_renderer.h"
#include "render/synth_scenario.h"
#include "slam/bow/vocabulary.h"
#include "slam/feature/orb_extractor.h"
#include "slam/system.h"

namespace lcv::slam {
namespace {

constexpr int kCols = 320, kRows = 180;
// ~0.9 m per frame around the 240 m ring: the slowest the sequence can be while the test stays
// short; at 220 frames (1.2 m per frame) tracking breaks in the corners.
constexpr int kFrames = 300;
constexpr double kFps = 10.0;

std::vector<cv::Mat> RenderClient(const render::Scenario& scenario, const CameraParams& camera) {
  render::SceneRenderer renderer(scenario.scene);
  std::vector<cv::Mat> images;
  for (const Rigid3d& cam_from_world : scenario.client_cam_from_world) {
    cv::Mat gray;
    cv::cvtColor(renderer.Render(camera, cam_from_world, render::SequenceKind::kClient), gray,
                 cv::COLOR_BGR2GRAY);
    images.push_back(gray);
  }
  return images;
}

std::shared_ptr<const Vocabulary> TrainVocabulary(const CameraParams& camera) {
  const render::Scenario other = render::MakeScenario("loop", 30, 2);
  render::SceneRenderer renderer(other.scene);
  OrbExtractorOptions extractor_options;
  OrbExtractor extractor(extractor_options);
  std::vector<std::vector<OrbDescriptor>> descriptors;
  std::vector<Keypoint> keypoints;
  for (const Rigid3d& cam_from_world : other.map_cam_from_world) {
    descriptors.emplace_back();
    extractor.Extract(renderer.Render(camera, cam_from_world, render::SequenceKind::kMap),
                      cv::Mat(), &keypoints, &descriptors.back());
  }
  VocabularyOptions options;
  options.branching = 10;
  options.depth = 4;
  return std::make_shared<const Vocabulary>(Vocabulary::Train(descriptors, options));
}

struct LoopRun {
  int tracked = 0;
  int initializations = 0;
  SystemStats stats;
  std::vector<TimedPose> keyframes;
  mapping::TrajectoryErrorReport ape;
};

class LoopClosingTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    camera_ = new CameraParams(render::SynthCamera(CameraModel::kPerspective, kCols, kRows, kFps));
    const render::Scenario scenario = render::MakeScenario("loop", kFrames, 1);
    images_ = new std::vector<cv::Mat>(RenderClient(scenario, *camera_));
    ground_truth_ = new mapping::Trajectory();
    for (int i = 0; i < kFrames; ++i) {
      ground_truth_->poses.push_back({i / kFps, scenario.client_cam_from_world[i]});
    }
    vocabulary_ = new std::shared_ptr<const Vocabulary>(TrainVocabulary(*camera_));
  }
  static void TearDownTestSuite() {
    delete camera_;
    delete images_;
    delete ground_truth_;
    delete vocabulary_;
  }

  static LoopRun Run(bool loop_closing, bool deterministic = true) {
    SystemOptions options;
    options.deterministic = deterministic;
    options.seed = 3;
    options.features.num_features = DefaultNumFeatures(CameraModel::kPerspective, kCols, kRows);
    options.keyframe_policy.max_frames = static_cast<int>(kFps);
    options.vocabulary = *vocabulary_;
    options.loop_closing.enabled = loop_closing;
    System system(*camera_, options);
    LoopRun run;
    for (int i = 0; i < kFrames; ++i) {
      const FrameResult r = system.TrackImage((*images_)[i], i / kFps);
      if (r.state == TrackingState::kTracking) ++run.tracked;
      if (std::getenv("LCV_TEST_VERBOSE")) {
        std::fprintf(stderr, "%d %s %d%s%s\n", i, TrackingStateName(r.state), r.num_matches,
                     r.is_keyframe ? " kf" : "", r.relocalized ? " reloc" : "");
      }
    }
    system.Finish();
    run.initializations = system.NumInitializations();
    run.stats = system.Stats();
    run.keyframes = system.KeyframeTrajectory();
    mapping::TrajectoryErrorOptions ape_options;
    ape_options.alignment = mapping::TrajectoryAlignment::kSim3;
    run.ape = mapping::ComputeApe(*ground_truth_, mapping::MakeTrajectory(system.FrameTrajectory()),
                                  ape_options);
    return run;
  }

  static CameraParams* camera_;
  static std::vector<cv::Mat>* images_;
  static mapping::Trajectory* ground_truth_;
  static std::shared_ptr<const Vocabulary>* vocabulary_;
};

CameraParams* LoopClosingTest::camera_ = nullptr;
std::vector<cv::Mat>* LoopClosingTest::images_ = nullptr;
mapping::Trajectory* LoopClosingTest::ground_truth_ = nullptr;
std::shared_ptr<const Vocabulary>* LoopClosingTest::vocabulary_ = nullptr;

TEST_F(LoopClosingTest, ClosesTheLoopWithTheStartAndLowersTheApe) {
  const LoopRun open = Run(false);
  const LoopRun closed = Run(true);
  ASSERT_FALSE(open.ape.problem) << *open.ape.problem;
  ASSERT_FALSE(closed.ape.problem) << *closed.ape.problem;
  std::printf("APE without loop closing %.3f m, with %.3f m; tracked %d / %d of %d; loops %d/%d\n",
              open.ape.translation.rmse, closed.ape.translation.rmse, open.tracked, closed.tracked,
              kFrames, closed.stats.loops_detected, closed.stats.loops_closed);

  // Both runs track the whole ring in one map (the comparison is about loop closing only).
  for (const LoopRun* run : {&open, &closed}) {
    EXPECT_EQ(run->initializations, 1);
    EXPECT_GE(run->tracked, kFrames * 95 / 100);
  }
  EXPECT_EQ(open.stats.loops_detected, 0);
  EXPECT_EQ(open.stats.loops_closed, 0);

  ASSERT_GE(closed.stats.loops_closed, 1);
  // The closed loop joins the revisit (last ~15% of the frames) with the start (first ~15%),
  // not two neighbouring keyframes.
  const double duration = (kFrames - 1) / kFps;
  bool start_to_revisit = false;
  for (const LoopEvent& loop : closed.stats.loops) {
    if (!loop.closed) continue;
    const auto match =
        std::find_if(closed.keyframes.begin(), closed.keyframes.end(),
                     [&](const TimedPose& k) { return k.id == loop.match_keyframe_id; });
    ASSERT_NE(match, closed.keyframes.end()) << "loop match keyframe " << loop.match_keyframe_id;
    start_to_revisit = start_to_revisit ||
                       (loop.timestamp > 0.85 * duration && match->timestamp < 0.15 * duration);
  }
  EXPECT_TRUE(start_to_revisit);

  // Every global BA run is recorded (--stats-out "global_ba"): what it solved and how it ended.
  int applied = 0;
  for (const SystemStats::GlobalBARun& run : closed.stats.global_ba) {
    if (!run.applied) continue;
    ++applied;
    EXPECT_GT(run.keyframes, 2);
    EXPECT_GT(run.points, 0);
    EXPECT_GT(run.observations, run.points);
    EXPECT_GT(run.iterations, 0);
    EXPECT_LE(run.final_cost, run.initial_cost);
    EXPECT_FALSE(run.message.empty());
  }
  EXPECT_GE(closed.stats.global_ba_runs, 1);
  EXPECT_EQ(applied, closed.stats.global_ba_runs);

  // Drift makes the open run's APE several metres here; the issue asks for >= 30% less.
  EXPECT_GT(open.ape.translation.rmse, 1.0);
  EXPECT_LT(closed.ape.translation.rmse, 0.7 * open.ape.translation.rmse)
      << "APE with loop closing " << closed.ape.translation.rmse << " m, without "
      << open.ape.translation.rmse << " m";
}

// The threads (issue 14): loop closing detects on a copy of the map and the writer corrects the
// live map, global BA solved by the stage and applied by the writer. Thread timing changes the
// keyframes, so only what must hold whatever the timing is checked: the revisit closes a loop
// in the one map, the writer ran the correction's pose graph, detection worked on copies handed
// over by the writer. Lock hold times are printed, not asserted (no timed assertions).
TEST_F(LoopClosingTest, ThreadedStageClosesTheLoopThroughTheMapWriter) {
  const LoopRun closed = Run(true, /*deterministic=*/false);
  ASSERT_FALSE(closed.ape.problem) << *closed.ape.problem;
  std::printf("threaded: APE %.3f m; tracked %d of %d; loops %d/%d; global BA runs %d; "
              "map lock max (tracking / mapping / loop closing) %.3f / %.3f / %.3f ms\n",
              closed.ape.translation.rmse, closed.tracked, kFrames, closed.stats.loops_detected,
              closed.stats.loops_closed, closed.stats.global_ba_runs,
              closed.stats.map_lock_tracking.max_ms, closed.stats.map_lock_mapping.max_ms,
              closed.stats.map_lock_loop_closing.max_ms);
  EXPECT_EQ(closed.initializations, 1);
  EXPECT_GE(closed.tracked, kFrames * 90 / 100);
  ASSERT_GE(closed.stats.loops_closed, 1);
  EXPECT_GE(closed.stats.pose_graph_runs, 1);
  EXPECT_GE(closed.stats.loop_input_copies, 1) << "detection ran on copies";
  EXPECT_GT(closed.stats.map_lock_loop_closing.count, 0);
  // Every keyframe reached loop detection, also those mapped while the stage was busy at the
  // end of the sequence (handed over by Finish: System::Impl::FlushLoopClosing).
  std::printf("threaded: %d keyframes handed to loop detection, %d of them at Finish\n",
              closed.stats.loop_input_keyframes, closed.stats.loop_input_keyframes_at_finish);
  EXPECT_GT(closed.stats.loop_input_keyframes, 0);
  EXPECT_EQ(closed.stats.loop_input_keyframes_unexamined, 0);
}

}  // namespace
}  // namespace lcv::slam
