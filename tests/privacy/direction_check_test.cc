#include "privacy/direction_check.h"

#include <gtest/gtest.h>

#include "tests/privacy/line_cloud_fixture.h"

namespace lcv::privacy {
namespace {

TEST(DirectionCheck, UniformDirectionsPass) {
  const std::uint64_t seed = 31;
  const slam::Map points = testing::MakeStreetPointMap(5000, seed);
  const slam::Map lines = testing::MakeLineCloud(points, seed);
  const DirectionCheckResult r = CheckDirections(lines, &points);
  EXPECT_TRUE(r.passed) << "seed " << seed;
  // rayleigh, bingham, 3 plane normals (two facades, ground), 3 keyframe axes.
  EXPECT_EQ(r.tests.size(), 8u);
}

TEST(DirectionCheck, FindsStreetPlanes) {
  const slam::Map points = testing::MakeStreetPointMap(5000, 3);
  std::vector<Eigen::Vector3d> p;
  for (const auto& [id, x] : points.points) p.push_back(x.position);
  const auto normals = DominantPlaneNormals(p, {});
  ASSERT_EQ(normals.size(), 3u);
  int along_x = 0, along_y = 0;
  for (const auto& n : normals) {
    along_x += std::abs(n.x()) > 0.99;
    along_y += std::abs(n.y()) > 0.99;
  }
  EXPECT_EQ(along_x, 2);  // facades x = +-w
  EXPECT_EQ(along_y, 1);  // ground
}

// Planted leak: 15% of the lines run along the facade normal (x); the rest are uniform.
TEST(DirectionCheck, LinesAlignedWithPlaneNormalFail) {
  const std::uint64_t seed = 32;
  const slam::Map points = testing::MakeStreetPointMap(5000, seed);
  slam::Map lines = testing::MakeLineCloud(points, seed);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0.0, 0.05);
  int k = 0;
  for (auto& [id, l] : lines.lines) {
    if (k++ % 7 != 0) continue;
    const Eigen::Vector3d x = points.points.at(id).position;
    Eigen::Vector3d d = Eigen::Vector3d(1.0, g(rng), g(rng)).normalized();
    if (k % 2) d = -d;  // axial: the sign carries nothing, so Rayleigh cannot see it
    l.line = slam::Line3d(x - d.dot(x) * d, d);
  }
  // Without a reference the keyframes' right axis stands for the facade normal.
  const DirectionCheckResult r = CheckDirections(lines, nullptr);
  EXPECT_FALSE(r.passed);
  bool right_axis_failed = false;
  for (const auto& t : r.tests) {
    if (t.name == "ks_keyframe_right") right_axis_failed = t.p_value < r.alpha_per_test;
  }
  EXPECT_TRUE(right_axis_failed);
  EXPECT_FALSE(CheckDirections(lines, &points).passed);
}

}  // namespace
}  // namespace lcv::privacy
