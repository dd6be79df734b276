#include "slam/geometry/line3.h"

#include <cmath>
#include <random>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

namespace lcv::slam {
namespace {

constexpr std::uint64_t kSeed = 2020;

Eigen::Vector3d RandomVector(std::mt19937_64& rng, double scale = 1.0) {
  std::normal_distribution<double> normal(0.0, scale);
  return Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
}

Line3d RandomLine(std::mt19937_64& rng) {
  return Line3d(RandomVector(rng, 5.0), RandomVector(rng).normalized());
}

Eigen::Matrix3d RandomCovariance(std::mt19937_64& rng) {
  Eigen::Matrix3d A;
  A.col(0) = RandomVector(rng);
  A.col(1) = RandomVector(rng);
  A.col(2) = RandomVector(rng);
  return A * A.transpose() + 0.05 * Eigen::Matrix3d::Identity();
}

TEST(Line3d, DistanceProjectionAndParameter) {
  const Line3d line(Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(0, 0, 1));
  const Eigen::Vector3d x(4, 6, -2);
  EXPECT_DOUBLE_EQ(line.Parameter(x), -5.0);
  EXPECT_LT((line.Project(x) - Eigen::Vector3d(1, 2, -2)).norm(), 1e-15);
  EXPECT_DOUBLE_EQ(line.Distance(x), 5.0);
  EXPECT_LT((line.Residual(x) - Eigen::Vector3d(3, 4, 0)).norm(), 1e-15);
  EXPECT_LT((line.PointAt(2.0) - Eigen::Vector3d(1, 2, 5)).norm(), 1e-15);
  // A point on the line is at distance 0, whatever the anchor.
  EXPECT_NEAR(line.Distance(line.PointAt(-7.3)), 0.0, 1e-14);
}

// |a(s_a) - b(s_b)| minimized the slow way: for each s_a the best s_b is a projection, and the
// remaining distance is convex in s_a: a coarse scan, then golden-section search.
double BruteForceDistance(const Line3d& a, const Line3d& b, double* s_a_out) {
  const auto distance_at = [&](double s_a) { return b.Distance(a.PointAt(s_a)); };
  double best_s = 0.0, best = distance_at(0.0);
  for (double s = -200.0; s <= 200.0; s += 0.05) {
    if (distance_at(s) < best) best = distance_at(best_s = s);
  }
  double lo = best_s - 0.05, hi = best_s + 0.05;
  const double ratio = 0.5 * (std::sqrt(5.0) - 1.0);
  for (int i = 0; i < 200; ++i) {
    const double m1 = hi - ratio * (hi - lo), m2 = lo + ratio * (hi - lo);
    if (distance_at(m1) < distance_at(m2)) {
      hi = m2;
    } else {
      lo = m1;
    }
  }
  *s_a_out = 0.5 * (lo + hi);
  return distance_at(*s_a_out);
}

TEST(Line3d, ClosestPointsAgreeWithBruteForce) {
  SCOPED_TRACE(::testing::Message() << "seed " << kSeed);
  std::mt19937_64 rng(kSeed);
  for (int trial = 0; trial < 50; ++trial) {
    const Line3d a = RandomLine(rng), b = RandomLine(rng);
    const double sin_angle = a.direction.cross(b.direction).norm();
    if (sin_angle < 0.1) continue;  // the optimum may lie beyond the brute-force scan
    const auto closest = ClosestPointsBetweenLines(a, b);
    ASSERT_TRUE(closest.has_value());
    double s_a_brute = 0.0;
    const double brute = BruteForceDistance(a, b, &s_a_brute);
    EXPECT_NEAR(closest->distance, brute, 1e-7);
    EXPECT_NEAR(closest->s_a, s_a_brute, 1e-5 / sin_angle);
    // The connecting segment is perpendicular to both lines.
    const Eigen::Vector3d gap = a.PointAt(closest->s_a) - b.PointAt(closest->s_b);
    EXPECT_NEAR(gap.dot(a.direction), 0.0, 1e-9);
    EXPECT_NEAR(gap.dot(b.direction), 0.0, 1e-9);
    EXPECT_NEAR(gap.norm(), closest->distance, 1e-12);
  }
}

TEST(Line3d, IntersectingAndParallelLines) {
  const Line3d a(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0));
  const Line3d b(Eigen::Vector3d(3, -2, 0), Eigen::Vector3d(0, 1, 0));
  const auto closest = ClosestPointsBetweenLines(a, b);
  ASSERT_TRUE(closest.has_value());
  EXPECT_NEAR(closest->s_a, 3.0, 1e-15);
  EXPECT_NEAR(closest->s_b, 2.0, 1e-15);
  EXPECT_NEAR(closest->distance, 0.0, 1e-15);

  const Line3d parallel(Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(-1, 0, 0));
  EXPECT_FALSE(ClosestPointsBetweenLines(a, parallel).has_value());
  const Line3d almost(Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(1, 1e-12, 0).normalized());
  EXPECT_FALSE(ClosestPointsBetweenLines(a, almost).has_value());
  EXPECT_TRUE(ClosestPointsBetweenLines(a, almost, 1e-13).has_value());
}

TEST(LineInformation, SymmetricPsdRankTwoWithDirectionInTheNullSpace) {
  SCOPED_TRACE(::testing::Message() << "seed " << kSeed);
  std::mt19937_64 rng(kSeed);
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Vector3d d = RandomVector(rng).normalized();
    const Eigen::Matrix3d sigma = RandomCovariance(rng);
    const Eigen::Matrix3d omega = LineInformation(d, sigma);
    ASSERT_TRUE(omega.allFinite());
    const double size = omega.norm();
    EXPECT_LT((omega - omega.transpose()).norm(), 1e-14 * size);
    EXPECT_LT((omega * d).norm(), 1e-12 * size);
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(omega);
    const Eigen::Vector3d values = eig.eigenvalues();  // ascending
    EXPECT_GT(values(0), -1e-12 * size);  // PSD
    EXPECT_LT(std::abs(values(0)), 1e-12 * size);  // rank 2
    EXPECT_GT(values(1), 1e-6 * size);
    // Moore-Penrose conditions of the pseudo-inverse of P Sigma P.
    const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - d * d.transpose();
    const Eigen::Matrix3d projected = P * sigma * P;
    EXPECT_LT((projected * omega * projected - projected).norm(), 1e-10 * projected.norm());
    EXPECT_LT((omega * projected * omega - omega).norm(), 1e-10 * size);
    // Quadratic form = the 2D Mahalanobis distance in the plane orthogonal to d.
    Eigen::Matrix<double, 3, 2> basis;
    basis.col(0) = d.unitOrthogonal();
    basis.col(1) = d.cross(basis.col(0));
    const Eigen::Matrix2d sigma_2d = basis.transpose() * sigma * basis;
    const Eigen::Vector3d x = RandomVector(rng);
    const Eigen::Vector2d x_2d = basis.transpose() * x;
    EXPECT_NEAR(x.dot(omega * x), x_2d.dot(sigma_2d.inverse() * x_2d),
                1e-9 * x_2d.dot(sigma_2d.inverse() * x_2d));
  }
}

TEST(LineInformation, IsotropicCovarianceGivesTheScaledProjector) {
  const Eigen::Vector3d d = Eigen::Vector3d(1, -2, 0.5).normalized();
  const double variance = 0.04;  // 20 cm standard deviation
  const Eigen::Matrix3d omega = LineInformation(d, variance * Eigen::Matrix3d::Identity());
  const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - d * d.transpose();
  EXPECT_LT((omega - P / variance).norm(), 1e-12);
  // x^T Omega x = |x orthogonal to d|^2 / variance; zero along d.
  const Eigen::Vector3d x(0.3, 0.1, -0.7);
  EXPECT_NEAR(x.dot(omega * x), (P * x).squaredNorm() / variance, 1e-12);
  EXPECT_NEAR((3.0 * d).dot(omega * (3.0 * d)), 0.0, 1e-12);
}

TEST(UniformUnitVector, UnitAndUniform) {
  std::mt19937_64 rng(kSeed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second_moment = Eigen::Matrix3d::Zero();
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d v = UniformUnitVector(uniform(rng), uniform(rng));
    EXPECT_NEAR(v.norm(), 1.0, 1e-14);
    mean += v / n;
    second_moment += v * v.transpose() / n;
  }
  // Uniform on the sphere: mean 0, E[v v^T] = I / 3 (standard error ~ 0.004 here).
  EXPECT_LT(mean.norm(), 0.03);
  EXPECT_LT((second_moment - Eigen::Matrix3d::Identity() / 3.0).norm(), 0.03);
}

}  // namespace
}  // namespace lcv::slam
