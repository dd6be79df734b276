#include "slam/match/area_matcher.h"

#include <gtest/gtest.h>

#include "tests/slam/match/matcher_test_util.h"

namespace lcv::slam {
namespace {

TEST(AreaMatcherTest, MatchesAcrossSmallMotionWithClutter) {
  const std::uint64_t seed = 41;
  SCOPED_TRACE("seed " + std::to_string(seed));
  const auto camera = MakeCamera(testing::SyntheticPinhole());
  const auto scene = testing::MakeSlabScene(1500, -3.0, 4.0, 4.0, 9.0, seed);
  const auto poses = testing::MakeLateralTrajectory(6, 0.1);
  std::mt19937_64 rng(seed + 1);
  testing::ObservationNoise noise;
  noise.clutter = 300;
  const auto s1 = testing::ObserveScene(scene, *camera, poses[0], noise, &rng);
  const auto s2 = testing::ObserveScene(scene, *camera, poses[5], noise, &rng);
  const Frame f1 = testing::MakeFrame(*camera, s1, poses[0], 0);
  const Frame f2 = testing::MakeFrame(*camera, s2, poses[5], 5);
  std::vector<Eigen::Vector2f> predicted;
  std::vector<int> matches;
  const int count = MatchInWindow(f1, f2, AreaMatchOptions(), &predicted, &matches);
  int correct = 0, wrong = 0, possible = 0;
  for (int i = 0; i < f1.num_keypoints(); ++i) {
    const int j = s1.point_index[i];
    if (j >= 0) {
      for (const int k : s2.point_index) possible += k == j;
    }
    if (matches[i] < 0) continue;
    (j >= 0 && s2.point_index[matches[i]] == j ? correct : wrong)++;
    EXPECT_EQ(predicted[i].x(), f2.keypoints[matches[i]].x);  // prediction follows the match
  }
  EXPECT_EQ(count, correct + wrong);
  EXPECT_GE(correct, 0.9 * possible) << correct << " of " << possible;
  EXPECT_LE(wrong, 0.01 * count);
  // One-to-one.
  std::vector<int> used(f2.num_keypoints(), 0);
  for (const int m : matches) {
    if (m >= 0) {
      EXPECT_EQ(used[m]++, 0);
    }
  }
}

TEST(AreaMatcherTest, WindowLimitsTheSearch) {
  const auto camera = MakeCamera(testing::SyntheticPinhole());
  const auto scene = testing::MakeSlabScene(800, -3.0, 4.0, 4.0, 9.0, 43);
  const auto poses = testing::MakeLateralTrajectory(11, 0.1);  // 1 m apart: > 50 px motion
  std::mt19937_64 rng(44);
  const auto s1 = testing::ObserveScene(scene, *camera, poses[0], testing::ObservationNoise(), &rng);
  const auto s2 = testing::ObserveScene(scene, *camera, poses[10], testing::ObservationNoise(), &rng);
  const Frame f1 = testing::MakeFrame(*camera, s1, poses[0], 0);
  const Frame f2 = testing::MakeFrame(*camera, s2, poses[10], 1);
  AreaMatchOptions options;
  options.window_px = 20.f;
  std::vector<Eigen::Vector2f> predicted;
  std::vector<int> matches;
  EXPECT_LT(MatchInWindow(f1, f2, options, &predicted, &matches), 20);
  options.window_px = 150.f;
  predicted.clear();
  EXPECT_GT(MatchInWindow(f1, f2, options, &predicted, &matches), 200);
}

}  // namespace
}  // namespace lcv::slam
