#include "slam/match/frame_matcher.h"

#include <random>

#include <gtest/gtest.h>

#include "slam/geometry/so3.h"
#include "tests/slam/match/matcher_test_util.h"

namespace lcv::slam {
namespace {

// Two views 25 degrees and 1 m apart: a third of the image width between the two images of a
// point, beyond any window, as across a sharp street corner.
struct TurnViews {
  testing::SyntheticScene scene;
  Rigid3d first, second;
};

TurnViews MakeTurnViews(std::uint64_t seed) {
  TurnViews views;
  views.scene = testing::MakeSlabScene(1500, -8.0, 8.0, 6.0, 14.0, seed);
  views.first = Rigid3d();
  const Rigid3d world_from_second(ExpSO3(Eigen::Vector3d(0.0, 25.0 * M_PI / 180.0, 0.0)),
                                  Eigen::Vector3d(1.0, 0.0, 0.5));
  views.second = world_from_second.Inverse();
  return views;
}

TEST(FrameMatcherTest, MatchesAcrossASharpTurnWithClutter) {
  for (const std::uint64_t seed : {61u, 62u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const auto camera = MakeCamera(testing::SyntheticPinhole());
    const TurnViews views = MakeTurnViews(seed);
    std::mt19937_64 rng(seed + 1);
    testing::ObservationNoise noise;
    noise.clutter = 300;
    const auto s1 = testing::ObserveScene(views.scene, *camera, views.first, noise, &rng);
    const auto s2 = testing::ObserveScene(views.scene, *camera, views.second, noise, &rng);
    const Frame f1 = testing::MakeFrame(*camera, s1, views.first, 0);
    const Frame f2 = testing::MakeFrame(*camera, s2, views.second, 1);
    const auto pairs = MatchFramesByDescriptor(f1, f2);
    int possible = 0;
    for (int i = 0; i < f1.num_keypoints(); ++i) {
      if (s1.point_index[i] < 0) continue;
      for (const int k : s2.point_index) possible += k == s1.point_index[i];
    }
    ASSERT_GT(possible, 300);
    int correct = 0, wrong = 0;
    std::vector<int> used(f2.num_keypoints(), 0);
    int previous = -1;
    for (const auto& [i, j] : pairs) {
      EXPECT_GT(i, previous);  // sorted by the first index, each first keypoint once
      previous = i;
      EXPECT_EQ(used[j]++, 0);  // each second keypoint once
      (s1.point_index[i] >= 0 && s1.point_index[i] == s2.point_index[j] ? correct : wrong)++;
    }
    EXPECT_GE(correct, 0.95 * possible) << correct << " of " << possible;
    EXPECT_LE(wrong, 0.01 * pairs.size());
  }
}

TEST(FrameMatcherTest, RejectsAmbiguousAndFarDescriptors) {
  const auto camera = MakeCamera(testing::SyntheticPinhole());
  TurnViews views = MakeTurnViews(63);
  // Three points that both views see: the second gets the first's descriptor (neither passes the
  // ratio test, whichever is nearer), the third's is far from itself in the second view
  // (Hamming > 64).
  std::vector<int> both;
  for (int j = 0; j < static_cast<int>(views.scene.points_in_world.size()) && both.size() < 3;
       ++j) {
    bool in_both = true;
    for (const Rigid3d* pose : {&views.first, &views.second}) {
      const Eigen::Vector3d p = *pose * views.scene.points_in_world[j];
      const auto px = camera->Project(p);
      in_both = in_both && p.z() > 0.1 && px && camera->InImage(*px, 5.0);
    }
    if (in_both) both.push_back(j);
  }
  ASSERT_EQ(both.size(), 3u);
  views.scene.descriptors[both[1]] = views.scene.descriptors[both[0]];
  std::mt19937_64 rng(64);
  testing::ObservationNoise noise;
  noise.flipped_bits = 0;
  noise.clutter = 0;
  const auto s1 = testing::ObserveScene(views.scene, *camera, views.first, noise, &rng);
  auto s2 = testing::ObserveScene(views.scene, *camera, views.second, noise, &rng);
  for (size_t k = 0; k < s2.point_index.size(); ++k) {
    if (s2.point_index[k] != both[2]) continue;
    for (int b = 0; b < 20; ++b) s2.descriptors[k][b] ^= 0xff;  // 160 bits flipped
  }
  const Frame f1 = testing::MakeFrame(*camera, s1, views.first, 0);
  const Frame f2 = testing::MakeFrame(*camera, s2, views.second, 1);
  const auto pairs = MatchFramesByDescriptor(f1, f2);
  EXPECT_GT(pairs.size(), 300u);
  for (const auto& [i, j] : pairs) {
    for (const int changed : both) {
      EXPECT_NE(s1.point_index[i], changed) << "point " << changed << " was matched";
    }
  }
}

TEST(FrameMatcherTest, OrientationHistogramDropsInconsistentRotations) {
  const auto camera = MakeCamera(testing::SyntheticPinhole());
  const TurnViews views = MakeTurnViews(65);
  std::mt19937_64 rng(66);
  testing::ObservationNoise noise;
  noise.clutter = 0;
  const auto s1 = testing::ObserveScene(views.scene, *camera, views.first, noise, &rng);
  auto s2 = testing::ObserveScene(views.scene, *camera, views.second, noise, &rng);
  // A twentieth of the second view's keypoints turned by 90 degrees: a minority rotation bin
  // (below 10% of the dominant one).
  for (size_t k = 0; k < s2.keypoints.size(); k += 20) s2.keypoints[k].angle_deg = 90.f;
  const Frame f1 = testing::MakeFrame(*camera, s1, views.first, 0);
  const Frame f2 = testing::MakeFrame(*camera, s2, views.second, 1);
  const auto checked = MatchFramesByDescriptor(f1, f2);
  int turned = 0;
  for (const auto& [i, j] : checked) turned += j % 20 == 0;
  EXPECT_EQ(turned, 0);
  FrameMatchOptions options;
  options.check_orientation = false;
  const auto unchecked = MatchFramesByDescriptor(f1, f2, options);
  turned = 0;
  for (const auto& [i, j] : unchecked) turned += j % 20 == 0;
  EXPECT_GT(turned, 10);
  EXPECT_GT(unchecked.size(), checked.size());
}

}  // namespace
}  // namespace lcv::slam
