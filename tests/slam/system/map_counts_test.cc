// Issue 16 item 9: the progress line of `lcv slam` reads System::NumKeyframes / NumLandmarks on
// the tracking thread while the mapping thread changes the map. They read counts the mapping
// side publishes (atomics), never the map itself. This test makes the same calls after every
// frame of a threaded run; under ThreadSanitizer (a -fsanitize=thread build) it fails if they
// touch the map again, and in any build it checks the counts against the final map.
#include <random>

#include <gtest/gtest.h>

#include "slam/system.h"
#include "tests/slam/system/synthetic_features.h"

namespace lcv::slam {
namespace {

TEST(SystemMapCounts, ReadableWhileTheMappingThreadRunsAndExactAfterFinish) {
  const CameraParams params = testing::SyntheticPinhole();
  const std::unique_ptr<Camera> camera = MakeCamera(params);
  constexpr int kFrames = 40;
  const testing::SyntheticScene scene =
      testing::MakeSlabScene(4000, -4.0, 0.1 * kFrames + 4.0, 4.0, 9.0, 5);
  const std::vector<Rigid3d> truth = testing::MakeLateralTrajectory(kFrames, 0.1);
  SystemOptions options;
  options.deterministic = false;  // the mapping thread runs
  options.seed = 5;
  System system(params, options);
  std::mt19937_64 rng(6);
  int max_keyframes_seen = 0;
  for (int i = 0; i < kFrames; ++i) {
    testing::SyntheticFrame frame =
        testing::ObserveScene(scene, *camera, truth[i], testing::ObservationNoise(), &rng);
    system.TrackFeatures(std::move(frame.keypoints), std::move(frame.descriptors), 0.1 * i);
    // What the progress line does, while a keyframe may be in the mapper's hands.
    const int keyframes = system.NumKeyframes();
    const int landmarks = system.NumLandmarks();
    EXPECT_GE(keyframes, 0);
    EXPECT_GE(landmarks, 0);
    max_keyframes_seen = std::max(max_keyframes_seen, keyframes);
  }
  system.Finish();
  const Map map = system.ExportMap();
  EXPECT_GE(max_keyframes_seen, 2) << "the counts never moved during the run";
  EXPECT_EQ(system.NumKeyframes(), static_cast<int>(map.keyframes.size()));
  EXPECT_GE(system.NumLandmarks(), static_cast<int>(map.points.size()));  // + unobserved
}

}  // namespace
}  // namespace lcv::slam
