#include "slam/geometry/so3.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace lcv::slam {
namespace {

constexpr std::uint64_t kSeed = 424242;

Eigen::Vector3d RandomAxis(std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  return Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
}

TEST(SO3, SkewSymmetricIsTheCrossProduct) {
  const Eigen::Vector3d v(0.3, -1.2, 2.0), w(-0.7, 0.1, 0.9);
  EXPECT_LT((SkewSymmetric(v) * w - v.cross(w)).norm(), 1e-15);
  EXPECT_LT((SkewSymmetric(v) + SkewSymmetric(v).transpose()).norm(), 1e-15);
}

TEST(SO3, ExpMatchesAngleAxis) {
  std::mt19937_64 rng(kSeed);
  for (double angle : {1e-12, 1e-8, 1e-5, 0.1, 1.0, 2.5, M_PI - 1e-9, M_PI}) {
    const Eigen::Vector3d axis = RandomAxis(rng);
    const Eigen::Quaterniond expected(Eigen::AngleAxisd(angle, axis));
    const Eigen::Quaterniond q = ExpSO3(angle * axis);
    EXPECT_NEAR(std::abs(q.dot(expected)), 1.0, 1e-15) << angle;
    EXPECT_NEAR(q.norm(), 1.0, 1e-15);
  }
}

TEST(SO3, LogInvertsExpIncludingTinyAndNearPiAngles) {
  SCOPED_TRACE(::testing::Message() << "seed " << kSeed);
  std::mt19937_64 rng(kSeed);
  for (double angle : {0.0, 1e-15, 1e-12, 1e-9, 1e-7, 1e-5, 0.3, 1.0, 3.0, M_PI - 1e-7,
                       M_PI - 1e-10}) {
    for (int trial = 0; trial < 20; ++trial) {
      const Eigen::Vector3d omega = angle * RandomAxis(rng);
      const Eigen::Vector3d back = LogSO3(ExpSO3(omega));
      // Near pi the axis is recovered with accuracy ~eps / (pi - angle) in its tilt; the
      // rotation itself is what must agree.
      EXPECT_LT(AngularDistance(ExpSO3(back), ExpSO3(omega)), 1e-14) << angle;
      if (angle < 3.0) {
        EXPECT_LT((back - omega).norm(), 1e-14 * std::max(1.0, angle)) << angle;
      }
      EXPECT_LE(back.norm(), M_PI + 1e-15);
    }
  }
  // q and -q are the same rotation: log gives the short way round.
  const Eigen::Quaterniond q = ExpSO3(Eigen::Vector3d(0, 0, 0.5));
  Eigen::Quaterniond minus_q;
  minus_q.coeffs() = -q.coeffs();
  EXPECT_LT((LogSO3(minus_q) - Eigen::Vector3d(0, 0, 0.5)).norm(), 1e-15);
}

// Exp(omega + delta) = Exp(J_l(omega) delta) Exp(omega) to first order: J_l from differences of
// Log(Exp(omega + delta) Exp(omega)^-1).
TEST(SO3, LeftJacobianMatchesCentralDifferences) {
  std::mt19937_64 rng(kSeed);
  for (double angle : {0.0, 1e-9, 1e-6, 1e-4, 9.99e-3, 1.001e-2, 0.5, 2.0, 3.1}) {
    const Eigen::Vector3d omega = angle * RandomAxis(rng);
    const Eigen::Quaterniond inverse = ExpSO3(omega).conjugate();
    Eigen::Matrix3d J_numeric;
    const double h = 1e-6;
    for (int i = 0; i < 3; ++i) {
      Eigen::Vector3d delta = Eigen::Vector3d::Zero();
      delta(i) = h;
      J_numeric.col(i) =
          (LogSO3(ExpSO3(omega + delta) * inverse) - LogSO3(ExpSO3(omega - delta) * inverse)) /
          (2 * h);
    }
    const Eigen::Matrix3d J = LeftJacobianSO3(omega);
    EXPECT_LT((J - J_numeric).norm(), 1e-8) << angle << "\n" << J << "\n" << J_numeric;
    EXPECT_LT((LeftJacobianInverseSO3(omega) * J - Eigen::Matrix3d::Identity()).norm(), 1e-13)
        << angle;
  }
}

// The closed form against its own power series sum_k W^k / (k + 1)! near the branch switches.
TEST(SO3, LeftJacobianIsAccurateAcrossBranchSwitches) {
  std::mt19937_64 rng(kSeed);
  for (double angle : {1e-8, 9.9e-7, 1.01e-6, 1e-5, 9.99e-3, 1.001e-2, 0.05}) {
    const Eigen::Vector3d omega = angle * RandomAxis(rng);
    const Eigen::Matrix3d W = SkewSymmetric(omega);
    Eigen::Matrix3d series = Eigen::Matrix3d::Identity();
    Eigen::Matrix3d term = Eigen::Matrix3d::Identity();
    for (int k = 1; k < 20; ++k) {
      term = term * W / (k + 1);
      series += term;
    }
    EXPECT_LT((LeftJacobianSO3(omega) - series).norm(), 2e-15) << angle;
    EXPECT_LT((LeftJacobianInverseSO3(omega) * series - Eigen::Matrix3d::Identity()).norm(),
              2e-15)
        << angle;
  }
}

TEST(SO3, AngularDistance) {
  const Eigen::Quaterniond a = ExpSO3(Eigen::Vector3d(0.1, 0.2, -0.3));
  const Eigen::Vector3d delta = Eigen::Vector3d(0.3, -0.4, 1.2);
  EXPECT_NEAR(AngularDistance(a, ExpSO3(delta) * a), delta.norm(), 1e-14);
  EXPECT_NEAR(AngularDistance(a, a), 0.0, 1e-15);
  EXPECT_NEAR(AngularDistance(Eigen::Quaterniond::Identity(), ExpSO3(Eigen::Vector3d(0, M_PI, 0))),
              M_PI, 1e-12);
}

}  // namespace
}  // namespace lcv::slam
