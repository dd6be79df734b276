#include "slam/geometry/rigid3.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <unsupported/Eigen/MatrixFunctions>

namespace lcv::slam {
namespace {

constexpr std::uint64_t kSeed = 31337;

Eigen::Vector3d RandomVector(std::mt19937_64& rng, double scale = 1.0) {
  std::normal_distribution<double> normal(0.0, scale);
  return Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
}

Rigid3d RandomPose(std::mt19937_64& rng) {
  return Rigid3d(ExpSO3(RandomVector(rng)), RandomVector(rng, 5.0));
}

Eigen::Matrix4d Homogeneous(const Rigid3d& T) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topRows<3>() = T.ToMatrix();
  return m;
}

// exp of the 4x4 twist [[omega]x, v; 0, 0], by Eigen's general matrix exponential.
Eigen::Matrix4d TwistExp(const Vector6d& delta) {
  Eigen::Matrix4d twist = Eigen::Matrix4d::Zero();
  twist.topLeftCorner<3, 3>() = SkewSymmetric(delta.tail<3>());
  twist.topRightCorner<3, 1>() = delta.head<3>();
  return twist.exp();
}

TEST(Rigid3d, ExpIsTheMatrixExponentialOfTheTwist) {
  std::mt19937_64 rng(kSeed);
  for (double angle : {0.0, 1e-12, 1e-8, 1e-6, 1e-3, 0.4, 2.0, M_PI - 1e-6}) {
    for (int trial = 0; trial < 10; ++trial) {
      Vector6d delta;
      delta.head<3>() = RandomVector(rng, 3.0);
      delta.tail<3>() = angle * RandomVector(rng).normalized();
      EXPECT_LT((Homogeneous(Rigid3d::Exp(delta)) - TwistExp(delta)).norm(), 1e-13) << angle;
    }
  }
}

TEST(Rigid3d, LogInvertsExp) {
  SCOPED_TRACE(::testing::Message() << "seed " << kSeed);
  std::mt19937_64 rng(kSeed);
  for (double angle : {0.0, 1e-14, 1e-9, 1e-6, 1e-2, 1.0, 3.0, M_PI - 1e-6}) {
    for (int trial = 0; trial < 20; ++trial) {
      Vector6d delta;
      delta.head<3>() = RandomVector(rng, 3.0);
      delta.tail<3>() = angle * RandomVector(rng).normalized();
      const Vector6d back = Rigid3d::Exp(delta).Log();
      EXPECT_LT((back - delta).norm(), 1e-9 * (angle > 3 ? 1.0 : 1e-3)) << angle;
    }
  }
  // And Exp(Log(T)) = T for random poses.
  for (int trial = 0; trial < 100; ++trial) {
    const Rigid3d T = RandomPose(rng);
    const Rigid3d back = Rigid3d::Exp(T.Log());
    EXPECT_LT(AngularDistance(back.rotation, T.rotation), 1e-14);
    EXPECT_LT((back.translation - T.translation).norm(), 1e-12);
  }
}

TEST(Rigid3d, CompositionAndInverseIdentities) {
  std::mt19937_64 rng(kSeed);
  for (int trial = 0; trial < 100; ++trial) {
    const Rigid3d c_from_b = RandomPose(rng), b_from_a = RandomPose(rng), a_from_z = RandomPose(rng);
    const Eigen::Vector3d x_in_a = RandomVector(rng, 10.0);
    // Points: (c_from_b * b_from_a) x = c_from_b (b_from_a x), and the 3x4 matrix agrees.
    const Rigid3d c_from_a = c_from_b * b_from_a;
    EXPECT_LT((c_from_a * x_in_a - c_from_b * (b_from_a * x_in_a)).norm(), 1e-12);
    EXPECT_LT((c_from_a.ToMatrix() * x_in_a.homogeneous() - c_from_a * x_in_a).norm(), 1e-12);
    EXPECT_LT((Homogeneous(c_from_a) - Homogeneous(c_from_b) * Homogeneous(b_from_a)).norm(),
              1e-12);
    // Associativity.
    const Rigid3d left = (c_from_b * b_from_a) * a_from_z;
    const Rigid3d right = c_from_b * (b_from_a * a_from_z);
    EXPECT_LT(AngularDistance(left.rotation, right.rotation), 1e-14);
    EXPECT_LT((left.translation - right.translation).norm(), 1e-12);
    // Inverse.
    const Rigid3d identity = c_from_a * c_from_a.Inverse();
    EXPECT_LT(AngularDistance(identity.rotation, Eigen::Quaterniond::Identity()), 1e-14);
    EXPECT_LT(identity.translation.norm(), 1e-12);
    EXPECT_LT((c_from_a.Inverse() * (c_from_a * x_in_a) - x_in_a).norm(), 1e-12);
    EXPECT_LT(((c_from_b * b_from_a).Inverse().translation -
               (b_from_a.Inverse() * c_from_b.Inverse()).translation)
                  .norm(),
              1e-12);
    // Matrix round trip.
    const Rigid3d from_matrix = Rigid3d::FromMatrix(c_from_a.ToMatrix());
    EXPECT_LT((from_matrix.ToMatrix() - c_from_a.ToMatrix()).norm(), 1e-14);
  }
}

TEST(Rigid3d, CenterIsMappedToTheOrigin) {
  std::mt19937_64 rng(kSeed);
  const Rigid3d cam_from_world = RandomPose(rng);
  EXPECT_LT((cam_from_world * cam_from_world.Center()).norm(), 1e-12);
  EXPECT_LT((cam_from_world.Center() - cam_from_world.Inverse().translation).norm(), 1e-12);
}

// The header's perturbation: T <- Exp(delta) T moves a transformed point y = T x by
// v + omega x y to first order.
TEST(Rigid3d, LeftPerturbationMovesPointsAsDocumented) {
  std::mt19937_64 rng(kSeed);
  const Rigid3d T = RandomPose(rng);
  const Eigen::Vector3d x = RandomVector(rng, 4.0);
  const Eigen::Vector3d y = T * x;
  Eigen::Matrix<double, 3, 6> J_numeric;
  const double h = 1e-6;
  for (int i = 0; i < 6; ++i) {
    Vector6d delta = Vector6d::Zero();
    delta(i) = h;
    J_numeric.col(i) = (Rigid3d::Exp(delta) * T * x - Rigid3d::Exp(-delta) * T * x) / (2 * h);
  }
  Eigen::Matrix<double, 3, 6> J;
  J.leftCols<3>() = Eigen::Matrix3d::Identity();
  J.rightCols<3>() = -SkewSymmetric(y);
  EXPECT_LT((J - J_numeric).norm(), 1e-8) << J_numeric;
}

}  // namespace
}  // namespace lcv::slam
