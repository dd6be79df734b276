#include "slam/geometry/sim3.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <unsupported/Eigen/MatrixFunctions>

namespace lcv::slam {
namespace {

constexpr std::uint64_t kSeed = 777;

Eigen::Vector3d RandomVector(std::mt19937_64& rng, double scale = 1.0) {
  std::normal_distribution<double> normal(0.0, scale);
  return Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
}

Sim3d RandomSim3(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> log_scale(-2.0, 2.0);
  return Sim3d(std::exp(log_scale(rng)), ExpSO3(RandomVector(rng)), RandomVector(rng, 5.0));
}

// exp of [[omega]x + sigma I, v; 0, 0] by Eigen's general matrix exponential.
Eigen::Matrix4d AlgebraExp(const Vector7d& delta) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  m.topLeftCorner<3, 3>() =
      SkewSymmetric(delta.segment<3>(3)) + delta(6) * Eigen::Matrix3d::Identity();
  m.topRightCorner<3, 1>() = delta.head<3>();
  return m.exp();
}

// Every mix of tiny, small, branch-switch and large angles and log-scales, exactly where the
// closed forms cancel.
const double kAngles[] = {0.0, 1e-14, 1e-9, 2e-8, 1e-6, 1e-3, 0.5, 0.999, 1.001, 2.0, M_PI - 1e-6};
const double kSigmas[] = {0.0,  1e-14, -1e-9, 2e-8, -1e-6, 1e-3, 0.5,
                          -0.999, 1.001, -1.5, 3.0};

TEST(Sim3d, ExpIsTheMatrixExponential) {
  std::mt19937_64 rng(kSeed);
  for (double angle : kAngles) {
    for (double sigma : kSigmas) {
      Vector7d delta;
      delta.head<3>() = RandomVector(rng, 2.0);
      delta.segment<3>(3) = angle * RandomVector(rng).normalized();
      delta(6) = sigma;
      const Eigen::Matrix4d expected = AlgebraExp(delta);
      EXPECT_LT((Sim3d::Exp(delta).ToMatrix() - expected).norm(), 1e-13 * expected.norm())
          << "angle " << angle << " sigma " << sigma;
    }
  }
}

TEST(Sim3d, LogInvertsExpWithScale) {
  SCOPED_TRACE(::testing::Message() << "seed " << kSeed);
  std::mt19937_64 rng(kSeed);
  for (double angle : kAngles) {
    for (double sigma : kSigmas) {
      Vector7d delta;
      delta.head<3>() = RandomVector(rng, 2.0);
      delta.segment<3>(3) = angle * RandomVector(rng).normalized();
      delta(6) = sigma;
      const Sim3d S = Sim3d::Exp(delta);
      const Vector7d back = S.Log();
      EXPECT_LT((back - delta).norm(), angle > 3.0 ? 1e-8 : 1e-12)
          << "angle " << angle << " sigma " << sigma;
      EXPECT_NEAR(S.scale, std::exp(sigma), 1e-15 * std::exp(sigma));
    }
  }
}

TEST(Sim3d, CompositionInverseAndPoints) {
  std::mt19937_64 rng(kSeed);
  for (int trial = 0; trial < 100; ++trial) {
    const Sim3d c_from_b = RandomSim3(rng), b_from_a = RandomSim3(rng);
    const Eigen::Vector3d x = RandomVector(rng, 3.0);
    const Sim3d c_from_a = c_from_b * b_from_a;
    EXPECT_LT((c_from_a * x - c_from_b * (b_from_a * x)).norm(), 1e-11);
    EXPECT_LT((c_from_a.ToMatrix() - c_from_b.ToMatrix() * b_from_a.ToMatrix()).norm(),
              1e-11 * c_from_a.ToMatrix().norm());
    EXPECT_LT((c_from_a.Inverse() * (c_from_a * x) - x).norm(), 1e-11);
    EXPECT_LT((c_from_a.Inverse().ToMatrix() - c_from_a.ToMatrix().inverse()).norm(),
              1e-11 * c_from_a.Inverse().ToMatrix().norm());
    const Sim3d identity = c_from_a * c_from_a.Inverse();
    EXPECT_NEAR(identity.scale, 1.0, 1e-14);
    EXPECT_LT(identity.translation.norm(), 1e-11);
    EXPECT_LT(AngularDistance(identity.rotation, Eigen::Quaterniond::Identity()), 1e-14);
  }
}

TEST(Sim3d, FromRigidKeepsTheTransform) {
  std::mt19937_64 rng(kSeed);
  const Rigid3d T(ExpSO3(RandomVector(rng)), RandomVector(rng));
  const Sim3d S(T);
  const Eigen::Vector3d x = RandomVector(rng);
  EXPECT_EQ(S.scale, 1.0);
  EXPECT_LT((S * x - T * x).norm(), 1e-15);
}

// A camera posed in world1, with the whole world moved by S into world2: it must see every
// point exactly as before, up to the scale of the world (its coordinates scale by s), and its
// centre moves with S.
TEST(Sim3d, TransformPoseMovesTheCameraWithTheWorld) {
  std::mt19937_64 rng(kSeed);
  for (int trial = 0; trial < 50; ++trial) {
    const Sim3d world2_from_world1 = RandomSim3(rng);
    const Rigid3d cam_from_world1(ExpSO3(RandomVector(rng)), RandomVector(rng, 3.0));
    const Rigid3d cam_from_world2 = TransformPose(world2_from_world1, cam_from_world1);
    EXPECT_NEAR(cam_from_world2.rotation.norm(), 1.0, 1e-14);
    EXPECT_LT((cam_from_world2.Center() - world2_from_world1 * cam_from_world1.Center()).norm(),
              1e-10);
    const Eigen::Vector3d x_in_world1 = RandomVector(rng, 4.0);
    const Eigen::Vector3d seen_before = cam_from_world1 * x_in_world1;
    const Eigen::Vector3d seen_after = cam_from_world2 * (world2_from_world1 * x_in_world1);
    EXPECT_LT((seen_after - world2_from_world1.scale * seen_before).norm(), 1e-10);
  }
  // The identity similarity changes nothing.
  const Rigid3d T(ExpSO3(Eigen::Vector3d(0.1, 0.2, 0.3)), Eigen::Vector3d(1, 2, 3));
  const Rigid3d same = TransformPose(Sim3d(), T);
  EXPECT_LT((same.translation - T.translation).norm(), 1e-15);
  EXPECT_LT(AngularDistance(same.rotation, T.rotation), 1e-15);
}

}  // namespace
}  // namespace lcv::slam
