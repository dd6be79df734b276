#include "slam/solve/triangulation.h"

#include <random>

#include <gtest/gtest.h>

#include "tests/slam/solve/solve_test_util.h"

namespace lcv::slam {
namespace {

TEST(Triangulation, ExactRaysGiveThePoint) {
  std::mt19937_64 rng(1);
  for (int trial = 0; trial < 50; ++trial) {
    const Rigid3d cam1(test::RandomRotation(rng), test::RandomUnit(rng) * 3.0);
    const Rigid3d cam2(test::RandomRotation(rng), test::RandomUnit(rng) * 3.0);
    const Eigen::Vector3d point = test::RandomUnit(rng) * 8.0;
    const Eigen::Vector3d p1 = cam1 * point, p2 = cam2 * point;
    const auto result = TriangulateBearings(cam1, cam2, p1.normalized(), p2.normalized());
    if ((cam1.Center() - cam2.Center()).cross(point - cam1.Center()).norm() < 1e-3) continue;
    ASSERT_TRUE(result.has_value());
    EXPECT_LT((result->point_in_world - point).norm(), 1e-8);
    EXPECT_NEAR(result->depth1, p1.norm(), 1e-8);
    EXPECT_NEAR(result->depth2, p2.norm(), 1e-8);
    const Eigen::Vector3d r1 = point - cam1.Center(), r2 = point - cam2.Center();
    EXPECT_NEAR(std::cos(result->parallax_rad), r1.normalized().dot(r2.normalized()), 1e-10);
  }
}

TEST(Triangulation, RejectsBehindParallelAndLowParallax) {
  const Rigid3d cam1;
  const Rigid3d cam2(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-1, 0, 0));  // centre +x
  const Eigen::Vector3d point(0.5, 0, 10);
  const Eigen::Vector3d b1 = (cam1 * point).normalized(), b2 = (cam2 * point).normalized();
  ASSERT_TRUE(TriangulateBearings(cam1, cam2, b1, b2).has_value());
  // Rays pointing away from each other: the closest points are behind the cameras.
  EXPECT_FALSE(TriangulateBearings(cam1, cam2, -b1, -b2).has_value());
  // Parallel rays.
  EXPECT_FALSE(TriangulateBearings(cam1, cam2, Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitZ())
                   .has_value());
  // Parallax of this point is ~5.7 degrees.
  EXPECT_TRUE(TriangulateBearings(cam1, cam2, b1, b2, 0.09).has_value());
  EXPECT_FALSE(TriangulateBearings(cam1, cam2, b1, b2, 0.11).has_value());
  // Same centre: no baseline.
  EXPECT_FALSE(TriangulateBearings(cam1, cam1, b1, b2).has_value());
}

TEST(Triangulation, PointsBehindPerspectiveAxisButInFrontAlongRays) {
  // A 360 degree camera sees a point behind its optical axis: positive depth along the rays.
  const Rigid3d cam1;
  const Rigid3d cam2(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-1, 0, 0));
  const Eigen::Vector3d point(0.3, 0.2, -6);
  const auto result = TriangulateBearings(cam1, cam2, (cam1 * point).normalized(),
                                          (cam2 * point).normalized());
  ASSERT_TRUE(result.has_value());
  EXPECT_LT((result->point_in_world - point).norm(), 1e-9);
  EXPECT_GT(result->depth1, 0.0);
}

TEST(Triangulation, NoisyRaysBoundedError) {
  std::mt19937_64 rng(2);
  const Rigid3d cam1;
  const Rigid3d cam2(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-1, 0, 0));
  double worst = 0.0;
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Vector3d point = test::RandomPointInView(rng, 0.5, 4.0, 8.0);
    const auto result = TriangulateBearings(
        cam1, cam2, test::PerturbBearing(cam1 * point, 1e-3, rng),
        test::PerturbBearing(cam2 * point, 1e-3, rng));
    ASSERT_TRUE(result.has_value());
    worst = std::max(worst, (result->point_in_world - point).norm() / point.norm());
  }
  // Depth error ~ depth * noise / parallax: 8 * 4e-3 / 0.12 rad -> < 0.3 relative.
  EXPECT_LT(worst, 0.3);
}

}  // namespace
}  // namespace lcv::slam
