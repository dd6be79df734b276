#include "slam/solve/absolute_pose.h"

#include <random>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <gtest/gtest.h>

#include "slam/solve/bearing_error.h"
#include "tests/slam/solve/solve_test_util.h"

namespace lcv::slam {
namespace {

struct PnPScene {
  Rigid3d cam_from_world;
  std::vector<Eigen::Vector3d> bearings, points;
  std::vector<char> is_inlier;
};

PnPScene MakeScene(std::uint64_t seed, int n, double noise_rad, double outlier_ratio, bool wide) {
  std::mt19937_64 rng(seed);
  PnPScene scene;
  scene.cam_from_world = Rigid3d(test::RandomRotation(rng), test::RandomUnit(rng) * 3.0);
  const Rigid3d world_from_cam = scene.cam_from_world.Inverse();
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d p_in_cam = wide ? test::RandomUnit(rng) * 6.0
                                          : test::RandomPointInView(rng, 0.6, 3.0, 12.0);
    const bool outlier = i < outlier_ratio * n;
    scene.points.push_back(world_from_cam * p_in_cam);
    scene.bearings.push_back(outlier ? test::RandomUnit(rng)
                                     : test::PerturbBearing(p_in_cam, noise_rad, rng));
    scene.is_inlier.push_back(!outlier);
  }
  return scene;
}

double RotationError(const Rigid3d& a, const Rigid3d& b) {
  return AngularDistance(a.rotation, b.rotation);
}

TEST(AbsolutePose, RansacRecoversPoseAndInliers) {
  for (bool wide : {false, true}) {
    for (double outliers : {0.3, 0.5}) {
      SCOPED_TRACE(std::string(wide ? "wide" : "narrow") + " outliers " +
                   std::to_string(outliers));
      const PnPScene scene = MakeScene(3, 300, 5e-4, outliers, wide);
      AbsolutePoseOptions options;
      options.max_angular_error_rad = 3e-3;
      options.ransac.random_seed = 11;
      const AbsolutePoseResult result = EstimateAbsolutePose(scene.bearings, scene.points, options);
      ASSERT_TRUE(result.success);
      EXPECT_LT(RotationError(result.cam_from_world, scene.cam_from_world), 2e-3);
      EXPECT_LT((result.cam_from_world.translation - scene.cam_from_world.translation).norm(),
                0.02);
      int correct = 0;
      for (int i = 0; i < 300; ++i) correct += result.inlier_mask[i] == scene.is_inlier[i];
      EXPECT_GE(correct, 295);
    }
  }
}

TEST(AbsolutePose, ExactDataRefinementKeepsTruth) {
  const PnPScene scene = MakeScene(4, 50, 0.0, 0.0, false);
  AbsolutePoseOptions options;
  options.max_angular_error_rad = 1e-6;
  const AbsolutePoseResult result = EstimateAbsolutePose(scene.bearings, scene.points, options);
  ASSERT_TRUE(result.success);
  EXPECT_EQ(result.num_inliers, 50);
  EXPECT_LT(RotationError(result.cam_from_world, scene.cam_from_world), 1e-8);
  EXPECT_LT((result.cam_from_world.translation - scene.cam_from_world.translation).norm(), 1e-8);
}

TEST(AbsolutePose, FailsOnTooFewOrPureNoise) {
  AbsolutePoseOptions options;
  std::vector<Eigen::Vector3d> two(2, Eigen::Vector3d::UnitZ());
  EXPECT_FALSE(EstimateAbsolutePose(two, two, options).success);
  const PnPScene noise = MakeScene(5, 100, 0.0, 1.0, false);
  options.max_angular_error_rad = 1e-3;
  options.ransac.min_inlier_ratio = 0.2;
  EXPECT_FALSE(EstimateAbsolutePose(noise.bearings, noise.points, options).success);
}

TEST(RefineAbsolutePose, ConvergesFromPerturbedPose) {
  const PnPScene scene = MakeScene(6, 100, 1e-3, 0.0, true);
  std::mt19937_64 rng(6);
  Vector6d delta;
  for (int k = 0; k < 6; ++k) delta(k) = std::normal_distribution<double>(0, 0.05)(rng);
  Rigid3d pose = Rigid3d::Exp(delta) * scene.cam_from_world;
  PoseRefinementOptions options;
  options.max_iterations = 20;
  double cost = 0;
  ASSERT_GE(RefineAbsolutePose(scene.bearings.data(), scene.points.data(), 100, nullptr, options,
                               &pose, &cost),
            1);
  EXPECT_LT(RotationError(pose, scene.cam_from_world), 1e-3);
  EXPECT_LT((pose.translation - scene.cam_from_world.translation).norm(), 0.01);
  // 100 residuals of 2 components with sigma 1e-3: cost ~ 2e-4.
  EXPECT_LT(cost, 5e-4);

  std::vector<int> too_few = {0, 1};
  EXPECT_EQ(RefineAbsolutePose(scene.bearings.data(), scene.points.data(), 100, &too_few,
                               options, &pose),
            -1);
}

// The analytic Jacobian of the refiner, rebuilt here as the refiner does, against central
// differences through the left perturbation.
TEST(RefineAbsolutePose, JacobianMatchesCentralDifferences) {
  std::mt19937_64 rng(7);
  const Rigid3d pose(test::RandomRotation(rng), test::RandomUnit(rng));
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Vector3d point = pose.Inverse() * test::RandomPointInView(rng, 1.0, 2.0, 5.0);
    const Eigen::Vector3d bearing = test::PerturbBearing(pose * point, 0.01, rng);
    const Eigen::Matrix<double, 3, 2> basis = TangentBasis(bearing);
    const Eigen::Vector3d p = pose * point;
    const Eigen::Vector3d u = p.normalized();
    const Eigen::Matrix<double, 2, 3> J_e_p =
        basis.transpose() * (Eigen::Matrix3d::Identity() - u * u.transpose()) / p.norm();
    Eigen::Matrix<double, 2, 6> J;
    J.leftCols<3>() = J_e_p;
    J.rightCols<3>() = -J_e_p * SkewSymmetric(p);
    Eigen::Matrix<double, 2, 6> J_numeric;
    const double h = 1e-6;
    for (int k = 0; k < 6; ++k) {
      Vector6d delta = Vector6d::Zero();
      delta(k) = h;
      const Eigen::Vector2d plus = TangentError(basis, Rigid3d::Exp(delta) * pose * point);
      const Eigen::Vector2d minus = TangentError(basis, Rigid3d::Exp(-delta) * pose * point);
      J_numeric.col(k) = (plus - minus) / (2 * h);
    }
    EXPECT_LT((J - J_numeric).norm(), 1e-7 * (1.0 + J.norm()));
  }
}

// Ceres twin: the same cost (tangent-plane errors, same basis) with autodiff and Ceres'
// quaternion manifold converges to the same pose as the hand-written Gauss-Newton.
struct TangentCost {
  TangentCost(const Eigen::Vector3d& bearing, const Eigen::Vector3d& point)
      : basis(TangentBasis(bearing)), point(point) {}
  template <typename T>
  bool operator()(const T* q_xyzw, const T* t, T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> q(q_xyzw);
    const Eigen::Matrix<T, 3, 1> p = q * point.cast<T>() + Eigen::Map<const Eigen::Matrix<T, 3, 1>>(t);
    const Eigen::Matrix<T, 3, 1> u = p / p.norm();
    const Eigen::Matrix<T, 2, 1> e = basis.transpose().cast<T>() * u;
    residual[0] = e(0);
    residual[1] = e(1);
    return true;
  }
  Eigen::Matrix<double, 3, 2> basis;
  Eigen::Vector3d point;
};

TEST(RefineAbsolutePose, AgreesWithCeresTwin) {
  const PnPScene scene = MakeScene(8, 200, 2e-3, 0.0, true);
  std::mt19937_64 rng(8);
  Vector6d delta;
  for (int k = 0; k < 6; ++k) delta(k) = std::normal_distribution<double>(0, 0.02)(rng);
  const Rigid3d start = Rigid3d::Exp(delta) * scene.cam_from_world;

  Rigid3d hand = start;
  PoseRefinementOptions options;
  options.max_iterations = 30;
  options.min_step = 1e-14;
  RefineAbsolutePose(scene.bearings.data(), scene.points.data(), 200, nullptr, options, &hand);

  Eigen::Quaterniond q = start.rotation;
  Eigen::Vector3d t = start.translation;
  ceres::Problem problem;
  for (int i = 0; i < 200; ++i) {
    problem.AddResidualBlock(new ceres::AutoDiffCostFunction<TangentCost, 2, 4, 3>(
                                 new TangentCost(scene.bearings[i], scene.points[i])),
                             nullptr, q.coeffs().data(), t.data());
  }
  problem.SetManifold(q.coeffs().data(), new ceres::EigenQuaternionManifold);
  ceres::Solver::Options solver_options;
  solver_options.max_num_iterations = 100;
  solver_options.function_tolerance = 1e-16;
  solver_options.gradient_tolerance = 1e-16;
  solver_options.parameter_tolerance = 1e-14;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  const Rigid3d twin(q.normalized(), t);
  EXPECT_LT(RotationError(hand, twin), 1e-8);
  EXPECT_LT((hand.translation - twin.translation).norm(), 1e-8);
}

}  // namespace
}  // namespace lcv::slam
