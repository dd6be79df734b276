#include "slam/solve/p3l_known_rotation.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "slam/geometry/so3.h"
#include "slam/solve/p6l.h"
#include "tests/slam/solve/solve_test_util.h"

namespace lcv::slam {
namespace {

constexpr double kPi = 3.14159265358979323846;

using test::LineScene;

// The p6L tests' scenes (solve_test_util.h) in a perspective camera's cone.
LineScene MakeScene(std::uint64_t seed, int n, double noise_rad, double outlier_ratio) {
  return test::MakeLineScene(seed, 40.0 * kPi / 180.0, n, noise_rad, outlier_ratio);
}

double CentreError(const Rigid3d& a, const Rigid3d& b) {
  return (a.Inverse().translation - b.Inverse().translation).norm();
}

TEST(CentreKnownRotation, ThreeExactCorrespondencesGiveTheCentre) {
  for (std::uint64_t seed = 1; seed <= 20; ++seed) {
    const LineScene scene = MakeScene(seed, 3, 0.0, 0.0);
    const auto pose = SolveCentreKnownRotation(scene.cam_from_world.rotation,
                                               scene.bearings.data(), scene.lines.data(),
                                               {0, 1, 2});
    ASSERT_TRUE(pose) << "seed " << seed;
    EXPECT_LT(CentreError(*pose, scene.cam_from_world), 1e-8) << "seed " << seed;
    EXPECT_LT(AngularDistance(pose->rotation, scene.cam_from_world.rotation), 1e-12);
  }
}

TEST(CentreKnownRotation, ParallelLinesAreDegenerate) {
  // Every plane normal d x R b is orthogonal to the common direction d: the centre is free
  // along d.
  LineScene scene = MakeScene(3, 5, 0.0, 0.0);
  for (Line3d& line : scene.lines) line.direction = Eigen::Vector3d::UnitY();
  EXPECT_FALSE(SolveCentreKnownRotation(scene.cam_from_world.rotation, scene.bearings.data(),
                                        scene.lines.data(), {0, 1, 2, 3, 4}));
  EXPECT_FALSE(SolveCentreKnownRotation(scene.cam_from_world.rotation, scene.bearings.data(),
                                        scene.lines.data(), {0, 1}));  // too few
}

TEST(CentreKnownRotation, RansacFindsTheCentreAmongOutliersAndNoise) {
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    // 1 mrad bearing noise (~0.5 px at 500 px focal), 60% outliers: p6L would need thousands
    // of samples (0.4^6), three-point samples need ~100.
    const LineScene scene = MakeScene(seed, 200, 1e-3, 0.6);
    const CentreKnownRotationEstimator estimator(scene.cam_from_world.rotation,
                                                 scene.bearings.data(), scene.lines.data(), 200);
    RansacOptions options;
    options.max_error = 4e-3;
    options.max_num_trials = 2000;
    options.random_seed = seed;
    const RansacReport<Rigid3d> report = Ransac(options, estimator);
    ASSERT_TRUE(report.success) << "seed " << seed;
    EXPECT_LT(CentreError(report.model, scene.cam_from_world), 0.05) << "seed " << seed;
    int right = 0, inliers = 0;
    for (int i = 0; i < 200; ++i) {
      inliers += report.inlier_mask[i];
      right += report.inlier_mask[i] && scene.is_inlier[i];
    }
    EXPECT_GE(right, 76) << "seed " << seed;  // of 80 true inliers
    EXPECT_GE(right, inliers * 9 / 10) << "seed " << seed;
    EXPECT_LT(report.num_trials, 2000) << "seed " << seed;
  }
}

TEST(CentreKnownRotation, AWrongRotationIsCorrectedByTheSixDofRefinement) {
  // The localizer's use: the rotation prior 1 degree off, the centre found with it, then
  // RefineP6L frees all six degrees of freedom on the inliers.
  const LineScene scene = MakeScene(7, 150, 1e-3, 0.5);
  const Eigen::Quaterniond off =
      ExpSO3(Eigen::Vector3d(1.0, -0.5, 0.3).normalized() * (1.0 * kPi / 180.0)) *
      scene.cam_from_world.rotation;
  const CentreKnownRotationEstimator estimator(off, scene.bearings.data(), scene.lines.data(), 150);
  RansacOptions options;
  options.max_error = 0.03;  // a wide first gate: the prior's error moves every plane
  options.max_num_trials = 2000;
  const RansacReport<Rigid3d> report = Ransac(options, estimator);
  ASSERT_TRUE(report.success);
  std::vector<int> inliers;
  for (int i = 0; i < 150; ++i) {
    if (report.inlier_mask[i]) inliers.push_back(i);
  }
  Rigid3d pose = report.model;
  P6LRefinementOptions refinement;
  refinement.huber_threshold_rad = 4e-3;
  ASSERT_GE(RefineP6L(scene.bearings.data(), scene.lines.data(), 150, &inliers, refinement, &pose),
            0);
  EXPECT_LT(CentreError(pose, scene.cam_from_world), 0.05);
  EXPECT_LT(AngularDistance(pose.rotation, scene.cam_from_world.rotation) * 180.0 / kPi, 0.2);
}

}  // namespace
}  // namespace lcv::slam
