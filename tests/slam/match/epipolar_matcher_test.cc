#include "slam/match/epipolar_matcher.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "slam/geometry/so3.h"
#include "tests/slam/match/matcher_test_util.h"

namespace lcv::slam {
namespace {

TEST(EpipolarMatcherTest, PairsFreeKeypointsConsistentWithTheEpipolarGeometry) {
  const std::uint64_t seed = 51;
  SCOPED_TRACE("seed " + std::to_string(seed));
  const auto camera = MakeCamera(testing::SyntheticPinhole());
  const auto scene = testing::MakeSlabScene(1200, -3.0, 4.0, 4.0, 9.0, seed);
  const auto poses = testing::MakeLateralTrajectory(6, 0.1);
  std::mt19937_64 rng(seed + 1);
  testing::ObservationNoise noise;
  noise.clutter = 300;
  const auto s1 = testing::ObserveScene(scene, *camera, poses[0], noise, &rng);
  const auto s2 = testing::ObserveScene(scene, *camera, poses[5], noise, &rng);
  SlamMap map;
  const Id k1 = map.AddKeyframe(testing::MakeFrame(*camera, s1, poses[0], 0)).id;
  const Id k2 = map.AddKeyframe(testing::MakeFrame(*camera, s2, poses[5], 5)).id;
  // Half of kf1's keypoints already hold a landmark: they must not be paired again.
  const Id landmark = map.AddLandmark(Eigen::Vector3d(0, 0, 5), k1).id;
  SlamKeyframe& kf1 = *map.FindKeyframe(k1);
  for (size_t i = 0; i < kf1.landmark_ids.size(); i += 2) kf1.landmark_ids[i] = landmark;

  EpipolarMatchOptions options;
  options.radians_per_pixel = RadiansPerPixel(*camera);
  EXPECT_NEAR(options.radians_per_pixel, 1.0 / 500.0, 1e-5);
  std::vector<std::pair<int, int>> matches;
  const int count = MatchForTriangulation(kf1, *map.FindKeyframe(k2), options, &matches);
  EXPECT_EQ(count, static_cast<int>(matches.size()));
  int correct = 0, wrong = 0;
  const Rigid3d cam2_from_cam1 = poses[5] * poses[0].Inverse();
  const Eigen::Matrix3d E = SkewSymmetric(cam2_from_cam1.translation) * cam2_from_cam1.RotationMatrix();
  const SlamKeyframe& kf2 = *map.FindKeyframe(k2);
  for (const auto& [i1, i2] : matches) {
    EXPECT_EQ(i1 % 2, 1) << "keypoint with a landmark was paired";
    const int j = s1.point_index[i1];
    (j >= 0 && s2.point_index[i2] == j ? correct : wrong)++;
    const Eigen::Vector3d n = (E * kf1.bearings[i1]).normalized();
    EXPECT_LT(std::abs(n.dot(kf2.bearings[i2])), 2.5 * options.radians_per_pixel * options.sigma_factor);
  }
  int possible = 0;
  for (size_t i = 1; i < s1.point_index.size(); i += 2) {
    const int j = s1.point_index[i];
    if (j < 0) continue;
    for (const int k : s2.point_index) possible += k == j;
  }
  EXPECT_GE(correct, 0.8 * possible) << correct << " of " << possible;
  EXPECT_LE(wrong, 0.02 * count);
}

// Every octave's own epipolar tolerance decides, at every position of the vectorized prefilter
// and its scalar tail: pairs 0.9 of their octave's tolerance off the epipolar plane are matched,
// pairs 1.1 of it off are not (a prefilter bound tighter than the largest octave's would lose the
// first of high octaves; a wrong index in the prefilter would pair wrong keypoints).
TEST(EpipolarMatcherTest, EachOctaveKeepsItsOwnTolerance) {
  std::mt19937_64 rng(57);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::uniform_int_distribution<int> byte(0, 255);
  SlamKeyframe kf1, kf2;
  kf1.id = 1;
  kf2.id = 2;
  kf2.cam_from_world.translation = Eigen::Vector3d(-1.0, 0.0, 0.0);  // centre at x = 1
  const Rigid3d cam2_from_cam1 = kf2.cam_from_world * kf1.cam_from_world.Inverse();
  const Eigen::Matrix3d E =
      SkewSymmetric(cam2_from_cam1.translation) * cam2_from_cam1.RotationMatrix();
  EpipolarMatchOptions options;
  options.radians_per_pixel = 1.0 / 300.0;
  options.check_orientation = false;
  // 8 octaves x {inside, outside} x 5 = 80 pairs, then 3 unpaired keypoints in kf2 so that its
  // free count is not a multiple of 4 (the scalar tail runs too).
  std::vector<bool> inside;
  for (int i = 0; i < 80; ++i) {
    const int octave = i % 8;
    const bool in = (i / 8) % 2 == 0;
    Eigen::Vector3d f1;
    do {
      f1 = Eigen::Vector3d(0.5 * uniform(rng), uniform(rng), 1.0).normalized();
    } while (std::abs(f1.x()) > 0.4);
    const Eigen::Vector3d normal = (E * f1).normalized();
    // In the epipolar plane: the direction to the point at depth 4 seen from camera 2.
    const Eigen::Vector3d in_plane = (cam2_from_cam1.RotationMatrix() * (4.0 * f1) +
                                      cam2_from_cam1.translation)
                                         .normalized();
    const double tolerance = std::sin(options.sigma_factor * kf2.scale_levels.Scale(octave) *
                                      options.radians_per_pixel);
    const double angle = std::asin((in ? 0.9 : 1.1) * tolerance);
    const Eigen::Vector3d f2 = std::cos(angle) * in_plane + std::sin(angle) * normal;
    OrbDescriptor descriptor;
    for (auto& b : descriptor) b = static_cast<std::uint8_t>(byte(rng));
    for (SlamKeyframe* kf : {&kf1, &kf2}) {
      Keypoint keypoint;
      keypoint.octave = octave;
      keypoint.angle_deg = 0.f;
      kf->keypoints.push_back(keypoint);
      kf->descriptors.push_back(descriptor);
      kf->landmark_ids.push_back(kInvalidId);
    }
    kf1.bearings.push_back(f1);
    kf2.bearings.push_back(f2);
    inside.push_back(in);
  }
  for (int i = 0; i < 3; ++i) {
    OrbDescriptor descriptor;
    for (auto& b : descriptor) b = static_cast<std::uint8_t>(byte(rng));
    kf2.keypoints.push_back(Keypoint{});
    kf2.descriptors.push_back(descriptor);
    kf2.landmark_ids.push_back(kInvalidId);
    kf2.bearings.push_back(Eigen::Vector3d(uniform(rng), uniform(rng), 1.0).normalized());
  }

  std::vector<std::pair<int, int>> matches;
  MatchForTriangulation(kf1, kf2, options, &matches);
  std::vector<int> matched(80, -1);
  for (const auto& [i1, i2] : matches) matched[i1] = i2;
  for (int i = 0; i < 80; ++i) {
    SCOPED_TRACE("pair " + std::to_string(i) + ", octave " + std::to_string(i % 8));
    EXPECT_EQ(matched[i], inside[i] ? i : -1);
  }
}

TEST(EpipolarMatcherTest, NoBaselineNoMatches) {
  const auto camera = MakeCamera(testing::SyntheticPinhole());
  const auto scene = testing::MakeSlabScene(300, -3.0, 3.0, 4.0, 9.0, 53);
  const auto pose = testing::MakeLateralTrajectory(1, 0.1)[0];
  std::mt19937_64 rng(54);
  const auto s = testing::ObserveScene(scene, *camera, pose, testing::ObservationNoise(), &rng);
  SlamMap map;
  const Id k1 = map.AddKeyframe(testing::MakeFrame(*camera, s, pose, 0)).id;
  const Id k2 = map.AddKeyframe(testing::MakeFrame(*camera, s, pose, 1)).id;
  std::vector<std::pair<int, int>> matches;
  EXPECT_EQ(MatchForTriangulation(*map.FindKeyframe(k1), *map.FindKeyframe(k2),
                                  EpipolarMatchOptions(), &matches),
            0);
}

}  // namespace
}  // namespace lcv::slam
