// Omega_vL propagated from Omega_L (residuals.h, VirtualObservationInformation).
#include <gtest/gtest.h>

#include <random>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "slam/geometry/so3.h"
#include "slam/optimize/residuals.h"

namespace lcv::slam {
namespace {

struct Case {
  Rigid3d cam_from_world;
  Line3d line;
  Eigen::Vector3d observed_normal;
  Eigen::Matrix3d information;
};

Case RandomCase(std::mt19937_64* rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0), c(-1.0, 1.0);
  Case k;
  k.cam_from_world.rotation = ExpSO3(Eigen::Vector3d(0.3 * c(*rng), 0.3 * c(*rng), 0.3 * c(*rng)));
  k.cam_from_world.translation = Eigen::Vector3d(c(*rng), c(*rng), c(*rng));
  const Eigen::Vector3d point = k.cam_from_world.Inverse() *
                                Eigen::Vector3d(2 * c(*rng), c(*rng), 4.0 + 6.0 * u(*rng));
  k.line = Line3d(point, UniformUnitVector(u(*rng), u(*rng)));
  Eigen::Matrix3d A = Eigen::Matrix3d::Random();
  const Eigen::Matrix3d covariance = 1e-4 * (A * A.transpose() + Eigen::Matrix3d::Identity());
  k.information = LineInformation(k.line.direction, covariance);
  // A slightly different observed normal (the observation is not at the current state).
  k.observed_normal =
      (LinePlaneNormal(k.cam_from_world, k.line) + Eigen::Vector3d(0.01, -0.02, 0.005)).normalized();
  return k;
}

TEST(VirtualObservationInformation, AnchorJacobianMatchesCentralDifferences) {
  std::mt19937_64 rng(11);
  for (int trial = 0; trial < 50; ++trial) {
    SCOPED_TRACE("seed 11, trial " + std::to_string(trial));
    const Case k = RandomCase(&rng);
    Eigen::Matrix<double, 2, 3> J;
    ASSERT_TRUE(VirtualObservationAnchorJacobian(k.cam_from_world, k.line, k.observed_normal, &J));
    Eigen::Matrix<double, 2, 3> numeric;
    const double h = 1e-6;
    for (int i = 0; i < 3; ++i) {
      Line3d plus = k.line, minus = k.line;
      plus.anchor(i) += h;
      minus.anchor(i) -= h;
      Eigen::Vector2d rp, rm;
      ASSERT_TRUE(VirtualObservationResidual(k.cam_from_world, plus, k.observed_normal, &rp));
      ASSERT_TRUE(VirtualObservationResidual(k.cam_from_world, minus, k.observed_normal, &rm));
      numeric.col(i) = (rp - rm) / (2 * h);
    }
    EXPECT_LT((J - numeric).norm(), 1e-6 * (1.0 + numeric.norm())) << J << "\n" << numeric;
    // Moving the anchor along the line changes nothing.
    EXPECT_LT((J * k.line.direction).norm(), 1e-9 * (1.0 + J.norm()));
  }
}

TEST(VirtualObservationInformation, MatchesMonteCarloPropagationOfTheLineCovariance) {
  std::mt19937_64 rng(12);
  const Case k = RandomCase(&rng);
  const double floor_rad = 1e-3;
  const Eigen::Matrix2d information =
      VirtualObservationInformation(k.cam_from_world, k.line, k.observed_normal, k.information,
                                    floor_rad);
  // Sample anchors from N(p_L, pinv(Omega_L)) and measure the residual's covariance.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(k.information);
  Eigen::Matrix3d sqrt_covariance = Eigen::Matrix3d::Zero();
  for (int i = 0; i < 3; ++i) {
    const double v = eig.eigenvalues()(i);
    if (v > 1e-9 * eig.eigenvalues().maxCoeff()) {
      sqrt_covariance += eig.eigenvectors().col(i) * eig.eigenvectors().col(i).transpose() /
                         std::sqrt(v);
    }
  }
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::Vector2d r0;
  ASSERT_TRUE(VirtualObservationResidual(k.cam_from_world, k.line, k.observed_normal, &r0));
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();
  const int n = 20000;
  for (int s = 0; s < n; ++s) {
    Line3d line = k.line;
    line.anchor += sqrt_covariance * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    Eigen::Vector2d r;
    ASSERT_TRUE(VirtualObservationResidual(k.cam_from_world, line, k.observed_normal, &r));
    covariance += (r - r0) * (r - r0).transpose() / n;
  }
  covariance.diagonal().array() += floor_rad * floor_rad;
  const Eigen::Matrix2d expected = information.inverse();
  EXPECT_LT((covariance - expected).norm(), 0.05 * expected.norm())
      << "Monte Carlo\n" << covariance << "\npropagated\n" << expected;
  // Symmetric positive definite, and no stronger than the floor allows.
  EXPECT_LT((information - information.transpose()).norm(), 1e-9 * information.norm());
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> e2(information);
  EXPECT_GT(e2.eigenvalues().minCoeff(), 0.0);
  EXPECT_LE(e2.eigenvalues().maxCoeff(), 1.0 / (floor_rad * floor_rad) * (1 + 1e-9));
}

TEST(VirtualObservationInformation, FloorOnlyAtTheCameraCentre) {
  const Rigid3d identity;
  const Line3d through_centre(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX());
  const Eigen::Matrix2d information = VirtualObservationInformation(
      identity, through_centre, Eigen::Vector3d::UnitZ(),
      LineInformation(Eigen::Vector3d::UnitX(), Eigen::Matrix3d::Identity()), 0.01);
  EXPECT_NEAR(information(0, 0), 1e4, 1e-6);
  EXPECT_NEAR(information(0, 1), 0.0, 1e-12);
}

}  // namespace
}  // namespace lcv::slam

namespace lcv::slam {
namespace {

TEST(LineIntersectionResidual, JacobianMatchesCentralDifferencesThroughTheRetraction) {
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    SCOPED_TRACE("seed 13, trial " + std::to_string(trial));
    const Line3d moving(Eigen::Vector3d(u(rng), u(rng), u(rng)) * 5,
                        UniformUnitVector(u(rng), u(rng)));
    const Line3d fixed(Eigen::Vector3d(u(rng), u(rng), u(rng)) * 5,
                       UniformUnitVector(u(rng), u(rng)));
    double r;
    Eigen::Matrix<double, 1, 4> J;
    ASSERT_TRUE(LineIntersectionResidual(moving, fixed, &r, &J));
    EXPECT_NEAR(std::abs(r), ClosestPointsBetweenLines(moving, fixed)->distance, 1e-9);
    Eigen::Matrix<double, 1, 4> numeric;
    const double h = 1e-6;
    for (int i = 0; i < 4; ++i) {
      Eigen::Vector4d delta = Eigen::Vector4d::Zero();
      delta(i) = h;
      double rp, rm;
      ASSERT_TRUE(LineIntersectionResidual(RetractLine(moving, delta), fixed, &rp));
      ASSERT_TRUE(LineIntersectionResidual(RetractLine(moving, -delta), fixed, &rm));
      numeric(i) = (rp - rm) / (2 * h);
    }
    EXPECT_LT((J - numeric).norm(), 1e-6 * (1.0 + numeric.norm())) << J << "\n" << numeric;
  }
}

}  // namespace
}  // namespace lcv::slam
