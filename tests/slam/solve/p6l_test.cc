#include "slam/solve/p6l.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "slam/geometry/so3.h"
#include "tests/slam/solve/solve_test_util.h"

namespace lcv::slam {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Bearing layouts of the three camera models: the half angle of the cone of viewing directions
// around +z (perspective ~ 40 degrees, a fisheye beyond 90, an equirectangular image the whole
// sphere).
struct Layout {
  const char* name;
  double half_fov_rad;
};
const Layout kLayouts[] = {{"perspective", 40.0 * kPi / 180.0},
                           {"fisheye", 100.0 * kPi / 180.0},
                           {"equirectangular", kPi}};

using test::LineScene;

LineScene MakeScene(std::uint64_t seed, const Layout& layout, int n, double noise_rad,
                    double outlier_ratio) {
  return test::MakeLineScene(seed, layout.half_fov_rad, n, noise_rad, outlier_ratio);
}

double RotationErrorDeg(const Rigid3d& a, const Rigid3d& b) {
  return AngularDistance(a.rotation, b.rotation) * 180.0 / kPi;
}
double CentreError(const Rigid3d& a, const Rigid3d& b) {
  return (a.Center() - b.Center()).norm();
}

TEST(P6L, ExactMinimalDataTruthAmongSolutionsForEveryLayout) {
  for (const Layout& layout : kLayouts) {
    int found = 0;
    const int trials = 40;
    for (int trial = 0; trial < trials; ++trial) {
      const LineScene scene = MakeScene(1000 + trial, layout, 6, 0.0, 0.0);
      std::vector<Rigid3d> solutions;
      const int count = SolveP6L(scene.bearings.data(), scene.lines.data(), 6, &solutions);
      ASSERT_EQ(count, static_cast<int>(solutions.size()));
      double best = 1e9;
      for (const Rigid3d& s : solutions) {
        ASSERT_TRUE(s.translation.allFinite() && s.rotation.coeffs().allFinite());
        best = std::min(best, RotationErrorDeg(s, scene.cam_from_world) * kPi / 180.0 +
                                  CentreError(s, scene.cam_from_world));
      }
      found += best < 1e-9;
    }
    // After the Gauss-Newton polish the truth is found to ~1e-13; the Groebner solver still
    // loses a root now and then on ill-conditioned samples (RANSAC draws another sample).
    EXPECT_GE(found, trials * 9 / 10) << layout.name;
  }
}

TEST(P6L, ResidualIsOrientationFreeAndRejectsPointsBehind) {
  const LineScene scene = MakeScene(7, kLayouts[0], 20, 0.0, 0.0);
  for (int i = 0; i < 20; ++i) {
    const Line3d& line = scene.lines[i];
    const Line3d flipped(line.anchor, -line.direction);
    EXPECT_LT(SquaredBearingPlaneError(scene.cam_from_world, scene.bearings[i], line), 1e-20);
    EXPECT_NEAR(SquaredBearingPlaneError(scene.cam_from_world, scene.bearings[i], flipped),
                SquaredBearingPlaneError(scene.cam_from_world, scene.bearings[i], line), 1e-15);
    // The opposite bearing lies in the same plane but meets the line behind the camera.
    EXPECT_EQ(SquaredBearingPlaneError(scene.cam_from_world, -scene.bearings[i], line), 4.0);
  }
  // A bearing rotated out of the plane by a known angle scores sin^2 of that angle.
  const Eigen::Vector3d a = scene.cam_from_world * scene.lines[0].anchor;
  const Eigen::Vector3d d = scene.cam_from_world.rotation * scene.lines[0].direction;
  const Eigen::Vector3d normal = a.cross(d).normalized();
  const double angle = 0.01;
  const Eigen::Vector3d tilted =
      (Eigen::AngleAxisd(angle, normal.cross(scene.bearings[0]).normalized()) * scene.bearings[0]);
  EXPECT_NEAR(SquaredBearingPlaneError(scene.cam_from_world, tilted, scene.lines[0]),
              std::pow(std::sin(angle), 2), 1e-12);
}

TEST(P6L, JacobianMatchesCentralDifferences) {
  const LineScene scene = MakeScene(11, kLayouts[1], 30, 0.01, 0.0);
  const double h = 1e-6;
  for (int i = 0; i < 30; ++i) {
    double r = 0.0;
    Eigen::Matrix<double, 1, 6> J;
    ASSERT_TRUE(BearingPlaneResidual(scene.cam_from_world, scene.bearings[i], scene.lines[i], &r,
                                     &J));
    Eigen::Matrix<double, 1, 6> numeric;
    for (int k = 0; k < 6; ++k) {
      Vector6d delta = Vector6d::Zero();
      delta[k] = h;
      double plus = 0.0, minus = 0.0;
      BearingPlaneResidual(Rigid3d::Exp(delta) * scene.cam_from_world, scene.bearings[i],
                           scene.lines[i], &plus, nullptr);
      BearingPlaneResidual(Rigid3d::Exp(-delta) * scene.cam_from_world, scene.bearings[i],
                           scene.lines[i], &minus, nullptr);
      numeric[k] = (plus - minus) / (2 * h);
    }
    EXPECT_LT((J - numeric).norm(), 1e-7 * std::max(1.0, J.norm())) << i << "\n"
                                                                     << J << "\n"
                                                                     << numeric;
  }
}

TEST(P6L, RefinementConvergesFromAPerturbedPose) {
  const LineScene scene = MakeScene(21, kLayouts[0], 100, 0.0, 0.0);
  std::mt19937_64 rng(5);
  Vector6d delta;
  delta << 0.05, -0.04, 0.03, 0.02, -0.01, 0.015;
  Rigid3d pose = Rigid3d::Exp(delta) * scene.cam_from_world;
  double cost = -1.0;
  const int iterations = RefineP6L(scene.bearings.data(), scene.lines.data(), 100, nullptr,
                                   P6LRefinementOptions(), &pose, &cost);
  ASSERT_GE(iterations, 1);
  EXPECT_LT(cost, 1e-18);
  EXPECT_LT(RotationErrorDeg(pose, scene.cam_from_world), 1e-6);
  EXPECT_LT(CentreError(pose, scene.cam_from_world), 1e-7);
}

TEST(P6L, DegenerateInputGivesNoSolutionAndNoNaN) {
  const LineScene scene = MakeScene(3, kLayouts[0], 6, 0.0, 0.0);
  std::vector<Rigid3d> solutions(3);
  EXPECT_EQ(SolveP6L(scene.bearings.data(), scene.lines.data(), 5, &solutions), 0);
  EXPECT_TRUE(solutions.empty());
  // All lines through the camera centre: the bearings carry no information.
  std::vector<Line3d> through_centre;
  const Eigen::Vector3d centre = scene.cam_from_world.Center();
  for (int i = 0; i < 6; ++i) through_centre.emplace_back(centre, scene.lines[i].direction);
  const int count = SolveP6L(scene.bearings.data(), through_centre.data(), 6, &solutions);
  for (const Rigid3d& s : solutions) {
    EXPECT_TRUE(s.translation.allFinite() && s.rotation.coeffs().allFinite());
  }
  EXPECT_EQ(count, static_cast<int>(solutions.size()));
  Rigid3d pose = scene.cam_from_world;
  EXPECT_EQ(RefineP6L(scene.bearings.data(), through_centre.data(), 6, nullptr,
                      P6LRefinementOptions(), &pose),
            -1);
}

// RANSAC on noisy data (1 px at ~500 px focal length) with 30% outliers, several poses, every
// layout: the pose is found and the inliers are the true ones.
TEST(P6L, RansacRecoversPoseWithOutliersForEveryLayout) {
  for (const Layout& layout : kLayouts) {
    for (int pose_seed = 0; pose_seed < 3; ++pose_seed) {
      const LineScene scene = MakeScene(300 + 10 * pose_seed, layout, 150, 0.002, 0.3);
      P6LOptions options;
      options.max_angular_error_rad = 0.008;
      options.ransac.random_seed = 42 + pose_seed;
      const P6LResult result = EstimateP6L(scene.bearings, scene.lines, options);
      ASSERT_TRUE(result.success) << layout.name << " pose " << pose_seed;
      EXPECT_LT(RotationErrorDeg(result.cam_from_world, scene.cam_from_world), 0.5)
          << layout.name << " pose " << pose_seed;
      EXPECT_LT(CentreError(result.cam_from_world, scene.cam_from_world), 0.05)
          << layout.name << " pose " << pose_seed;
      int true_inliers = 0, false_inliers = 0;
      for (int i = 0; i < 150; ++i) {
        true_inliers += result.inlier_mask[i] && scene.is_inlier[i];
        false_inliers += result.inlier_mask[i] && !scene.is_inlier[i];
      }
      EXPECT_GE(true_inliers, 100) << layout.name;  // of 105
      // A random bearing lies within 0.008 rad of a random line's plane by chance ~1% of the time.
      EXPECT_LE(false_inliers, 5) << layout.name;
    }
  }
}

TEST(P6L, RansacFailsOnPureOutliers) {
  const LineScene scene = MakeScene(77, kLayouts[0], 60, 0.0, 1.0);
  P6LOptions options;
  options.ransac.max_num_trials = 200;
  options.min_num_inliers = 20;
  const P6LResult result = EstimateP6L(scene.bearings, scene.lines, options);
  EXPECT_FALSE(result.success);
}

}  // namespace
}  // namespace lcv::slam
