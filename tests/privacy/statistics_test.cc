#include "privacy/statistics.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "slam/geometry/line3.h"

namespace lcv::privacy {
namespace {

TEST(Statistics, ChiSquareTailsMatchTables) {
  // 95% quantiles of chi2 with 1..5 dof.
  const double q95[5] = {3.841459, 5.991465, 7.814728, 9.487729, 11.070498};
  for (int k = 1; k <= 5; ++k) EXPECT_NEAR(ChiSquareUpperTail(q95[k - 1], k), 0.05, 1e-6) << k;
  EXPECT_DOUBLE_EQ(ChiSquareUpperTail(0.0, 3), 1.0);
  EXPECT_LT(ChiSquareUpperTail(100.0, 5), 1e-15);
}

TEST(Statistics, KolmogorovTailMatchesTable) {
  EXPECT_NEAR(KolmogorovUpperTail(1.3581), 0.05, 1e-4);
  EXPECT_NEAR(KolmogorovUpperTail(1.6276), 0.01, 1e-4);
}

TEST(Statistics, KsAcceptsUniformRejectsSkewed) {
  const std::uint64_t seed = 11;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<double> uniform, skewed;
  for (int i = 0; i < 5000; ++i) {
    uniform.push_back(u(rng));
    skewed.push_back(std::pow(u(rng), 1.3));
  }
  EXPECT_GT(KolmogorovSmirnovUniform(uniform, 0, 1).p_value, 1e-3) << "seed " << seed;
  EXPECT_LT(KolmogorovSmirnovUniform(skewed, 0, 1).p_value, 1e-6) << "seed " << seed;
}

TEST(Statistics, SphereTestsAcceptUniformRejectConcentrated) {
  const std::uint64_t seed = 5;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Eigen::Vector3d> uniform, signed_bias, girdle;
  for (int i = 0; i < 4000; ++i) {
    uniform.push_back(slam::UniformUnitVector(u(rng), u(rng)));
    Eigen::Vector3d d = slam::UniformUnitVector(u(rng), u(rng));
    signed_bias.push_back((d + Eigen::Vector3d(0.2, 0, 0)).normalized());
    Eigen::Vector3d g = slam::UniformUnitVector(u(rng), u(rng));
    g.z() *= 0.6;  // flattened towards the xy great circle, still symmetric under d -> -d
    girdle.push_back(g.normalized());
  }
  EXPECT_GT(RayleighTest(uniform).p_value, 1e-3);
  EXPECT_GT(BinghamTest(uniform).p_value, 1e-3);
  EXPECT_LT(RayleighTest(signed_bias).p_value, 1e-6);
  EXPECT_GT(RayleighTest(girdle).p_value, 1e-4);  // axial: invisible to Rayleigh...
  EXPECT_LT(BinghamTest(girdle).p_value, 1e-6);   // ...but not to Bingham
}

TEST(Statistics, MedianAndQuantile) {
  EXPECT_DOUBLE_EQ(Median({3, 1, 2}), 2.0);
  EXPECT_DOUBLE_EQ(Median({4, 1, 2, 3}), 2.5);
  EXPECT_TRUE(std::isinf(Median({1, INFINITY, INFINITY})));
  EXPECT_TRUE(std::isnan(Median({})));
  EXPECT_DOUBLE_EQ(Quantile({0, 10}, 0.25), 2.5);
}

}  // namespace
}  // namespace lcv::privacy
