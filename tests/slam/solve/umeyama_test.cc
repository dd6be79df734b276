#include "slam/solve/umeyama.h"

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "slam/geometry/so3.h"
#include "slam/solve/ransac.h"

namespace lcv::slam {
namespace {

constexpr std::uint64_t kSeed = 20200823;

Sim3d RandomSim3(std::mt19937_64& rng, double scale) {
  std::normal_distribution<double> normal(0.0, 1.0);
  const Eigen::Vector3d omega(normal(rng), normal(rng), normal(rng));
  const Eigen::Vector3d t(5 * normal(rng), 5 * normal(rng), 5 * normal(rng));
  return Sim3d(scale, ExpSO3(omega), t);
}

std::vector<Eigen::Vector3d> RandomPoints(std::mt19937_64& rng, int count) {
  std::uniform_real_distribution<double> uniform(-10.0, 10.0);
  std::vector<Eigen::Vector3d> points(count);
  for (auto& p : points) p = Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng));
  return points;
}

void ExpectSim3Near(const Sim3d& a, const Sim3d& b, double tolerance) {
  EXPECT_NEAR(a.scale, b.scale, tolerance * b.scale);
  EXPECT_LT(AngularDistance(a.rotation, b.rotation), tolerance);
  EXPECT_LT((a.translation - b.translation).norm(), tolerance * (1.0 + b.translation.norm()));
}

TEST(UmeyamaTest, ExactSimilarityAndRigidRecovered) {
  std::mt19937_64 rng(kSeed);
  for (int trial = 0; trial < 50; ++trial) {
    SCOPED_TRACE("seed " + std::to_string(kSeed) + " trial " + std::to_string(trial));
    const double scale = std::exp(std::uniform_real_distribution<double>(-2, 2)(rng));
    const Sim3d truth = RandomSim3(rng, scale);
    const int count = 3 + trial % 20;  // includes the minimal case
    const auto src = RandomPoints(rng, count);
    std::vector<Eigen::Vector3d> dst;
    for (const auto& p : src) dst.push_back(truth * p);
    Sim3d estimate;
    ASSERT_TRUE(AlignUmeyama(src, dst, true, &estimate));
    ExpectSim3Near(estimate, truth, 1e-8);

    // Rigid: same data with s = 1.
    const Sim3d rigid_truth(1.0, truth.rotation, truth.translation);
    std::vector<Eigen::Vector3d> rigid_dst;
    for (const auto& p : src) rigid_dst.push_back(rigid_truth * p);
    ASSERT_TRUE(AlignUmeyama(src, rigid_dst, false, &estimate));
    ExpectSim3Near(estimate, rigid_truth, 1e-8);
    EXPECT_EQ(estimate.scale, 1.0);
  }
}

TEST(UmeyamaTest, PlanarPointsAndReflectionFix) {
  // Coplanar points (rank 2 covariance) still give the proper rotation, not a reflection.
  std::mt19937_64 rng(kSeed + 1);
  const Sim3d truth = RandomSim3(rng, 0.3);
  std::vector<Eigen::Vector3d> src, dst;
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  for (int i = 0; i < 10; ++i) {
    src.emplace_back(uniform(rng), uniform(rng), 0.0);
    dst.push_back(truth * src.back());
  }
  Sim3d estimate;
  ASSERT_TRUE(AlignUmeyama(src, dst, true, &estimate));
  ExpectSim3Near(estimate, truth, 1e-8);
  EXPECT_NEAR(estimate.rotation.toRotationMatrix().determinant(), 1.0, 1e-12);
}

TEST(UmeyamaTest, NoisyDataHasBoundedError) {
  std::mt19937_64 rng(kSeed + 2);
  std::normal_distribution<double> noise(0.0, 0.01);
  const Sim3d truth = RandomSim3(rng, 2.5);
  const auto src = RandomPoints(rng, 200);
  std::vector<Eigen::Vector3d> dst;
  for (const auto& p : src) dst.push_back(truth * p + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
  Sim3d estimate;
  ASSERT_TRUE(AlignUmeyama(src, dst, true, &estimate));
  EXPECT_NEAR(estimate.scale, 2.5, 2.5e-3);
  EXPECT_LT(AngularDistance(estimate.rotation, truth.rotation), 1e-3);
  EXPECT_LT((estimate.translation - truth.translation).norm(), 0.02);
  // Least squares: no other transform (here: the truth) has a lower cost on the same data.
  double cost_estimate = 0, cost_truth = 0;
  for (size_t i = 0; i < src.size(); ++i) {
    cost_estimate += (dst[i] - estimate * src[i]).squaredNorm();
    cost_truth += (dst[i] - truth * src[i]).squaredNorm();
  }
  EXPECT_LE(cost_estimate, cost_truth);
}

TEST(UmeyamaTest, DegenerateInputReturnsFalseWithoutNaN) {
  Sim3d untouched(2.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 2, 3));
  Sim3d out = untouched;
  const std::vector<Eigen::Vector3d> two = {{0, 0, 0}, {1, 0, 0}};
  EXPECT_FALSE(AlignUmeyama(two, two, true, &out));
  const std::vector<Eigen::Vector3d> collinear = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {5, 5, 5}};
  EXPECT_FALSE(AlignUmeyama(collinear, collinear, true, &out));
  const std::vector<Eigen::Vector3d> same = {{1, 1, 1}, {1, 1, 1}, {1, 1, 1}};
  const std::vector<Eigen::Vector3d> spread = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  EXPECT_FALSE(AlignUmeyama(same, spread, true, &out));
  EXPECT_FALSE(AlignUmeyama(spread, same, true, &out));
  std::vector<Eigen::Vector3d> with_nan = spread;
  with_nan[1].x() = std::nan("");
  EXPECT_FALSE(AlignUmeyama(with_nan, spread, true, &out));
  EXPECT_FALSE(AlignUmeyama(spread, two, true, &out));  // size mismatch
  EXPECT_EQ(out.scale, untouched.scale);
  EXPECT_EQ(out.translation, untouched.translation);
}

TEST(UmeyamaTest, RansacWithOutliersRecoversSimilarityAndInliers) {
  std::mt19937_64 rng(kSeed + 3);
  std::normal_distribution<double> noise(0.0, 0.005);
  std::uniform_real_distribution<double> far(-30.0, 30.0);
  const Sim3d truth = RandomSim3(rng, 0.7);
  const int count = 100;
  const auto src = RandomPoints(rng, count);
  std::vector<Eigen::Vector3d> dst(count);
  std::vector<char> is_inlier(count, 1);
  for (int i = 0; i < count; ++i) {
    if (i % 5 < 2) {  // 40 % outliers
      dst[i] = Eigen::Vector3d(far(rng), far(rng), far(rng));
      is_inlier[i] = 0;
    } else {
      dst[i] = truth * src[i] + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    }
  }
  const Sim3PointEstimator estimator(src.data(), dst.data(), count);
  RansacOptions options;
  options.max_error = 0.05;
  options.random_seed = kSeed;
  const RansacReport<Sim3d> report = Ransac(options, estimator);
  ASSERT_TRUE(report.success) << "seed " << kSeed + 3;
  EXPECT_NEAR(report.model.scale, 0.7, 1e-3);
  EXPECT_LT(AngularDistance(report.model.rotation, truth.rotation), 2e-3);
  EXPECT_LT((report.model.translation - truth.translation).norm(), 0.02);
  int wrong = 0;
  for (int i = 0; i < count; ++i) wrong += (report.inlier_mask[i] != 0) != (is_inlier[i] != 0);
  EXPECT_LE(wrong, 2);
}

}  // namespace
}  // namespace lcv::slam
