#include "slam/solve/homography.h"

#include <random>

#include <gtest/gtest.h>

#include "slam/solve/ransac.h"
#include "tests/slam/solve/solve_test_util.h"

namespace lcv::slam {
namespace {

struct PlaneScene {
  Rigid3d cam2_from_cam1;
  Eigen::Vector3d normal;  // in camera 1, plane n.p = distance
  double distance = 0.0;
  std::vector<Eigen::Vector2d> u1, u2;
  std::vector<char> is_inlier;
};

PlaneScene MakePlaneScene(std::uint64_t seed, int n, double noise, double outlier_ratio) {
  std::mt19937_64 rng(seed);
  PlaneScene scene;
  scene.cam2_from_cam1 = Rigid3d(test::RandomRotation(rng, 0.2), test::RandomUnit(rng) * 0.5);
  scene.normal = (Eigen::Vector3d(0, 0, 1) + 0.3 * test::RandomUnit(rng)).normalized();
  scene.distance = 5.0;
  std::uniform_real_distribution<double> uniform(-0.5, 0.5);
  std::normal_distribution<double> normal(0.0, noise);
  while (static_cast<int>(scene.u1.size()) < n) {
    const Eigen::Vector3d ray(uniform(rng), uniform(rng), 1.0);
    const Eigen::Vector3d p1 = ray * (scene.distance / scene.normal.dot(ray));
    const Eigen::Vector3d p2 = scene.cam2_from_cam1 * p1;
    if (p2.z() < 0.5) continue;
    const bool outlier = scene.u1.size() < outlier_ratio * n;
    scene.u1.push_back(p1.hnormalized() + Eigen::Vector2d(normal(rng), normal(rng)));
    scene.u2.push_back(outlier ? Eigen::Vector2d(uniform(rng), uniform(rng))
                               : Eigen::Vector2d(p2.hnormalized() +
                                                 Eigen::Vector2d(normal(rng), normal(rng))));
    scene.is_inlier.push_back(!outlier);
  }
  return scene;
}

Eigen::Matrix3d TrueHomography(const PlaneScene& scene) {
  return scene.cam2_from_cam1.RotationMatrix() +
         scene.cam2_from_cam1.translation * scene.normal.transpose() / scene.distance;
}

double HomographyDistance(Eigen::Matrix3d a, Eigen::Matrix3d b) {
  a /= a.norm();
  b /= b.norm();
  return std::min((a - b).norm(), (a + b).norm());
}

TEST(Homography, ExactDataRecoversTruthAndDecomposition) {
  for (std::uint64_t seed = 1; seed <= 5; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const PlaneScene scene = MakePlaneScene(seed, 4, 0.0, 0.0);
    Eigen::Matrix3d H;
    ASSERT_EQ(HomographyDlt(scene.u1.data(), scene.u2.data(), 4, &H), 1);
    const Eigen::Matrix3d H_true = TrueHomography(scene);
    EXPECT_LT(HomographyDistance(H, H_true), 1e-8);
    EXPECT_NEAR(H.norm(), 1.0, 1e-12);
    for (int i = 0; i < 4; ++i) {
      EXPECT_LT(SquaredSymmetricTransferError(H, H.inverse(), scene.u1[i], scene.u2[i]), 1e-20);
    }
    std::vector<HomographyMotion> motions;
    ASSERT_GT(DecomposeHomography(H, &motions), 0);
    double best = 1e9;
    for (const auto& m : motions) {
      const double error = (m.R - scene.cam2_from_cam1.RotationMatrix()).norm() +
                           (m.t - scene.cam2_from_cam1.translation / scene.distance).norm() +
                           (m.n - scene.normal).norm();
      best = std::min(best, error);
      EXPECT_NEAR(m.R.determinant(), 1.0, 1e-9);
    }
    EXPECT_LT(best, 1e-8);
  }
}

TEST(Homography, NoisyDataBoundedError) {
  const PlaneScene scene = MakePlaneScene(7, 200, 1e-3, 0.0);
  Eigen::Matrix3d H;
  ASSERT_EQ(HomographyDlt(scene.u1.data(), scene.u2.data(), 200, &H), 1);
  EXPECT_LT(HomographyDistance(H, TrueHomography(scene)), 0.01);
}

TEST(Homography, DegenerateInputReturnsZero) {
  std::vector<Eigen::Vector2d> collinear = {{0, 0}, {1, 1}, {2, 2}, {0.5, -1}};
  std::vector<Eigen::Vector2d> other = {{0, 0}, {1, 0}, {0, 1}, {1, 1}};
  Eigen::Matrix3d H;
  EXPECT_EQ(HomographyDlt(collinear.data(), other.data(), 4, &H), 0);
  EXPECT_EQ(HomographyDlt(other.data(), collinear.data(), 4, &H), 0);
  EXPECT_EQ(HomographyDlt(other.data(), other.data(), 3, &H), 0);
  std::vector<Eigen::Vector2d> same(4, Eigen::Vector2d(0.3, 0.1));
  EXPECT_EQ(HomographyDlt(same.data(), same.data(), 4, &H), 0);
  // Pure rotation: H = R has equal singular values, no motion to decompose.
  std::vector<HomographyMotion> motions;
  EXPECT_EQ(DecomposeHomography(Eigen::Matrix3d::Identity(), &motions), 0);
  EXPECT_EQ(DecomposeHomography(Eigen::Matrix3d::Constant(NAN), &motions), 0);
}

TEST(Homography, RansacWithOutliers) {
  const PlaneScene scene = MakePlaneScene(9, 200, 5e-4, 0.45);
  RansacOptions options;
  options.max_error = 3e-3;
  options.random_seed = 9;
  const HomographyEstimator estimator(scene.u1.data(), scene.u2.data(), 200);
  const auto report = Ransac(options, estimator);
  ASSERT_TRUE(report.success);
  int correct = 0;
  for (int i = 0; i < 200; ++i) correct += report.inlier_mask[i] == scene.is_inlier[i];
  EXPECT_GE(correct, 196);
  EXPECT_LT(HomographyDistance(report.model, TrueHomography(scene)), 0.01);
}

}  // namespace
}  // namespace lcv::slam
