#include "slam/solve/p3p.h"

#include <random>

#include <gtest/gtest.h>

#include "tests/slam/solve/solve_test_util.h"

namespace lcv::slam {
namespace {

double PoseError(const Rigid3d& a, const Rigid3d& b) {
  return AngularDistance(a.rotation, b.rotation) + (a.translation - b.translation).norm();
}

double BestPoseError(const std::vector<Rigid3d>& poses, const Rigid3d& truth) {
  double best = 1e9;
  for (const auto& pose : poses) best = std::min(best, PoseError(pose, truth));
  return best;
}

TEST(P3P, ExactDataTruthAmongSolutions) {
  std::mt19937_64 rng(1);
  int solved = 0;
  for (int trial = 0; trial < 500; ++trial) {
    const Rigid3d world_from_cam(test::RandomRotation(rng), test::RandomUnit(rng) * 5.0);
    const Rigid3d cam_from_world = world_from_cam.Inverse();
    // Every other trial: a 360 degree camera sees points in any direction.
    const bool wide = trial % 2;
    Eigen::Vector3d bearings[3], points[3];
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d p_in_cam = wide ? test::RandomUnit(rng) * (1.0 + 9.0 * (rng() % 1000) / 1000.0)
                                            : test::RandomPointInView(rng, 0.7, 1.0, 10.0);
      bearings[i] = p_in_cam.normalized();
      points[i] = world_from_cam * p_in_cam;
    }
    std::vector<Rigid3d> poses;
    const int count = SolveP3P(bearings, points, &poses);
    ASSERT_LE(count, 4);
    ASSERT_EQ(count, static_cast<int>(poses.size()));
    ASSERT_GE(count, 1) << "trial " << trial;
    const double error = BestPoseError(poses, cam_from_world);
    EXPECT_LT(error, 1e-8) << "trial " << trial;
    solved += error < 1e-8;
    for (const auto& pose : poses) {
      // Every returned pose satisfies the equation: points at positive depth along the bearings.
      for (int i = 0; i < 3; ++i) {
        const Eigen::Vector3d p = pose * points[i];
        EXPECT_GT(p.dot(bearings[i]), 0.0);
        EXPECT_LT((p.normalized() - bearings[i]).norm(), 1e-6);
      }
    }
  }
  EXPECT_EQ(solved, 500);
}

TEST(P3P, NoisyDataBoundedError) {
  // Near the "danger" configurations two of the four solutions are close and noise can turn
  // them into a complex pair: then the truth has no real neighbour (PoseLib and Lambda Twist
  // behave alike). That must stay rare.
  std::mt19937_64 rng(2);
  int within_bound = 0;
  for (int trial = 0; trial < 100; ++trial) {
    const Rigid3d cam_from_world(test::RandomRotation(rng), test::RandomUnit(rng) * 2.0);
    const Rigid3d world_from_cam = cam_from_world.Inverse();
    Eigen::Vector3d bearings[3], points[3];
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d p_in_cam = test::RandomPointInView(rng, 0.7, 4.0, 8.0);
      bearings[i] = test::PerturbBearing(p_in_cam, 1e-4, rng);
      points[i] = world_from_cam * p_in_cam;
    }
    std::vector<Rigid3d> poses;
    SolveP3P(bearings, points, &poses);
    // Minimal problems amplify noise; bounded for a wide triangle.
    within_bound += BestPoseError(poses, cam_from_world) < 0.1;
  }
  EXPECT_GE(within_bound, 95);
}

TEST(P3P, DegenerateInputReturnsZero) {
  std::vector<Rigid3d> poses;
  Eigen::Vector3d bearings[3] = {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0.1, 0, 1).normalized(),
                                 Eigen::Vector3d(0, 0.1, 1).normalized()};
  // Collinear points.
  Eigen::Vector3d collinear[3] = {{0, 0, 5}, {1, 0, 5}, {2, 0, 5}};
  EXPECT_EQ(SolveP3P(bearings, collinear, &poses), 0);
  // Coincident points.
  Eigen::Vector3d same[3] = {{0, 0, 5}, {0, 0, 5}, {1, 1, 5}};
  EXPECT_EQ(SolveP3P(bearings, same, &poses), 0);
  // Identical bearings.
  Eigen::Vector3d parallel[3] = {Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitZ(),
                                 Eigen::Vector3d(0, 0.1, 1).normalized()};
  Eigen::Vector3d points[3] = {{0, 0, 5}, {1, 0, 5}, {0, 1, 5}};
  EXPECT_EQ(SolveP3P(parallel, points, &poses), 0);
  // NaN input.
  Eigen::Vector3d nan_bearings[3] = {Eigen::Vector3d::Constant(NAN), bearings[1], bearings[2]};
  EXPECT_EQ(SolveP3P(nan_bearings, points, &poses), 0);
  for (const auto& pose : poses) EXPECT_TRUE(pose.translation.allFinite());
}

}  // namespace
}  // namespace lcv::slam
