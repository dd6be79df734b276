#include "slam/solve/essential.h"

#include <random>

#include <gtest/gtest.h>

#include "slam/solve/ransac.h"
#include "slam/solve/triangulation.h"
#include "tests/slam/solve/solve_test_util.h"

namespace lcv::slam {
namespace {

struct TwoViewScene {
  Rigid3d cam2_from_cam1;
  std::vector<Eigen::Vector3d> bearings1, bearings2;
  std::vector<char> is_inlier;
};

// Points all around camera 1 (wide_fov: also behind it, as seen by a 360 degree camera), the
// second camera translated by ~1 unit and rotated.
TwoViewScene MakeScene(std::uint64_t seed, int n, double noise_rad, double outlier_ratio,
                       bool wide_fov) {
  std::mt19937_64 rng(seed);
  TwoViewScene scene;
  scene.cam2_from_cam1 = Rigid3d(test::RandomRotation(rng, 0.3),
                                 test::RandomUnit(rng) * 0.8);
  while (static_cast<int>(scene.bearings1.size()) < n) {
    const Eigen::Vector3d p1 = wide_fov ? test::RandomUnit(rng) * (3.0 + 5.0 * (rng() % 1000) / 1000.0)
                                        : test::RandomPointInView(rng, 0.6, 3.0, 10.0);
    const Eigen::Vector3d p2 = scene.cam2_from_cam1 * p1;
    if (!wide_fov && p2.z() < 0.5) continue;
    const bool outlier = scene.bearings1.size() < outlier_ratio * n;
    scene.bearings1.push_back(test::PerturbBearing(p1, noise_rad, rng));
    scene.bearings2.push_back(outlier ? test::RandomUnit(rng)
                                      : test::PerturbBearing(p2, noise_rad, rng));
    if (outlier && !wide_fov && scene.bearings2.back().z() < 0) scene.bearings2.back() *= -1;
    scene.is_inlier.push_back(!outlier);
  }
  return scene;
}

Eigen::Matrix3d TrueEssential(const Rigid3d& cam2_from_cam1) {
  Eigen::Matrix3d E = SkewSymmetric(cam2_from_cam1.translation.normalized()) *
                      cam2_from_cam1.RotationMatrix();
  return E;
}

double EssentialDistance(Eigen::Matrix3d a, Eigen::Matrix3d b) {
  a /= a.norm();
  b /= b.norm();
  return std::min((a - b).norm(), (a + b).norm());
}

TEST(EssentialMatrix, ExactDataRecoversTruth) {
  for (bool wide : {false, true}) {
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
      SCOPED_TRACE("seed " + std::to_string(seed) + (wide ? " wide" : " narrow"));
      const TwoViewScene scene = MakeScene(seed, 8, 0.0, 0.0, wide);
      Eigen::Matrix3d E;
      ASSERT_EQ(EssentialMatrixEightPoint(scene.bearings1.data(), scene.bearings2.data(), 8, &E),
                1);
      EXPECT_LT(EssentialDistance(E, TrueEssential(scene.cam2_from_cam1)), 1e-8);
      for (int i = 0; i < 8; ++i) {
        EXPECT_LT(SquaredEpipolarAngleError(E, scene.bearings1[i], scene.bearings2[i]), 1e-20);
      }
      Rigid3d pose;
      EXPECT_EQ(PoseFromEssentialMatrix(E, scene.bearings1.data(), scene.bearings2.data(), 8,
                                        nullptr, &pose),
                8);
      EXPECT_LT(AngularDistance(pose.rotation, scene.cam2_from_cam1.rotation), 1e-8);
      EXPECT_LT(test::TranslationAngle(pose.translation, scene.cam2_from_cam1.translation), 1e-8);
      EXPECT_NEAR(pose.translation.norm(), 1.0, 1e-12);
    }
  }
}

TEST(EssentialMatrix, SevenPointTruthAmongSolutions) {
  for (bool wide : {false, true}) {
    for (std::uint64_t seed = 1; seed <= 20; ++seed) {
      SCOPED_TRACE("seed " + std::to_string(seed) + (wide ? " wide" : " narrow"));
      const TwoViewScene scene = MakeScene(seed, 7, 0.0, 0.0, wide);
      std::vector<Eigen::Matrix3d> solutions;
      const int count =
          EssentialMatrixSevenPoint(scene.bearings1.data(), scene.bearings2.data(), &solutions);
      ASSERT_GE(count, 1);
      ASSERT_LE(count, 3);
      double best = 1e9;
      for (const auto& E : solutions) {
        EXPECT_TRUE(E.allFinite());
        best = std::min(best, EssentialDistance(E, TrueEssential(scene.cam2_from_cam1)));
      }
      EXPECT_LT(best, 1e-8);
    }
  }
  // Degenerate: identical pairs.
  std::vector<Eigen::Vector3d> same(7, Eigen::Vector3d::UnitZ());
  std::vector<Eigen::Matrix3d> solutions;
  EXPECT_EQ(EssentialMatrixSevenPoint(same.data(), same.data(), &solutions), 0);
}

TEST(EssentialMatrix, DecompositionGivesProperRotations) {
  const TwoViewScene scene = MakeScene(9, 20, 0.0, 0.0, false);
  Eigen::Matrix3d R1, R2;
  Eigen::Vector3d t;
  DecomposeEssentialMatrix(TrueEssential(scene.cam2_from_cam1), &R1, &R2, &t);
  EXPECT_NEAR(R1.determinant(), 1.0, 1e-12);
  EXPECT_NEAR(R2.determinant(), 1.0, 1e-12);
  EXPECT_LT((R1 * R1.transpose() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  const Eigen::Matrix3d R_true = scene.cam2_from_cam1.RotationMatrix();
  EXPECT_LT(std::min((R1 - R_true).norm(), (R2 - R_true).norm()), 1e-10);
}

TEST(EssentialMatrix, NoisyDataBoundedError) {
  const TwoViewScene scene = MakeScene(11, 200, 1e-3, 0.0, false);
  Eigen::Matrix3d E;
  ASSERT_EQ(EssentialMatrixEightPoint(scene.bearings1.data(), scene.bearings2.data(), 200, &E), 1);
  Rigid3d pose;
  EXPECT_GE(PoseFromEssentialMatrix(E, scene.bearings1.data(), scene.bearings2.data(), 200,
                                    nullptr, &pose),
            190);
  EXPECT_LT(AngularDistance(pose.rotation, scene.cam2_from_cam1.rotation), 0.01);
  EXPECT_LT(test::TranslationAngle(pose.translation, scene.cam2_from_cam1.translation), 0.05);
}

TEST(EssentialMatrix, DegenerateInputReturnsZero) {
  std::vector<Eigen::Vector3d> b1(8, Eigen::Vector3d::UnitZ()), b2(8, Eigen::Vector3d::UnitZ());
  Eigen::Matrix3d E = Eigen::Matrix3d::Constant(7.0);
  EXPECT_EQ(EssentialMatrixEightPoint(b1.data(), b2.data(), 8, &E), 0);
  EXPECT_EQ(EssentialMatrixEightPoint(b1.data(), b2.data(), 7, &E), 0);
  // Pure rotation: E = [0]x R = 0 is the only consistent matrix, the system is rank deficient.
  std::mt19937_64 rng(3);
  const Eigen::Quaterniond rotation = test::RandomRotation(rng, 0.3);
  for (int i = 0; i < 8; ++i) {
    b1[i] = test::RandomPointInView(rng, 0.5, 1, 5).normalized();
    b2[i] = rotation * b1[i];
  }
  const int solutions = EssentialMatrixEightPoint(b1.data(), b2.data(), 8, &E);
  if (solutions) EXPECT_TRUE(E.allFinite());
  Rigid3d pose;
  EXPECT_EQ(PoseFromEssentialMatrix(Eigen::Matrix3d::Zero(), b1.data(), b2.data(), 8, nullptr,
                                    &pose),
            0);
  std::vector<Eigen::Vector3d> nan_bearings(8, Eigen::Vector3d::Constant(NAN));
  EXPECT_EQ(EssentialMatrixEightPoint(nan_bearings.data(), b2.data(), 8, &E), 0);
}

TEST(EssentialMatrix, RansacWithOutliers) {
  for (bool wide : {false, true}) {
    SCOPED_TRACE(wide ? "wide" : "narrow");
    const TwoViewScene scene = MakeScene(21, 300, 5e-4, 0.4, wide);
    RansacOptions options;
    options.max_error = 3e-3;
    options.random_seed = 5;
    options.max_num_trials = 2000;
    const EssentialMatrixEstimator estimator(scene.bearings1.data(), scene.bearings2.data(), 300);
    const auto report = Ransac(options, estimator);
    ASSERT_TRUE(report.success);
    int true_inliers_found = 0, false_inliers = 0;
    for (int i = 0; i < 300; ++i) {
      true_inliers_found += report.inlier_mask[i] && scene.is_inlier[i];
      false_inliers += report.inlier_mask[i] && !scene.is_inlier[i];
    }
    EXPECT_GE(true_inliers_found, 175);  // of 180
    EXPECT_LE(false_inliers, 6);
    Rigid3d pose;
    PoseFromEssentialMatrix(report.model, scene.bearings1.data(), scene.bearings2.data(), 300,
                            report.inlier_mask.data(), &pose);
    EXPECT_LT(AngularDistance(pose.rotation, scene.cam2_from_cam1.rotation), 0.01);
    EXPECT_LT(test::TranslationAngle(pose.translation, scene.cam2_from_cam1.translation), 0.03);
  }
}

}  // namespace
}  // namespace lcv::slam

namespace lcv::slam {
namespace {

TEST(RefineRelativePose, ConvergesToTruthOnExactAndNoisyData) {
  for (double noise : {0.0, 1e-3}) {
    SCOPED_TRACE("noise " + std::to_string(noise));
    const TwoViewScene scene = MakeScene(31, 200, noise, 0.0, false);
    std::mt19937_64 rng(31);
    Rigid3d pose(test::RandomRotation(rng, 0.02) * scene.cam2_from_cam1.rotation,
                 (scene.cam2_from_cam1.translation.normalized() + 0.05 * test::RandomUnit(rng))
                     .normalized());
    ASSERT_GE(RefineRelativePose(scene.bearings1.data(), scene.bearings2.data(), 200, nullptr, 20,
                                 &pose),
              1);
    const double tolerance = noise > 0 ? 3e-3 : 1e-9;
    EXPECT_LT(AngularDistance(pose.rotation, scene.cam2_from_cam1.rotation), tolerance);
    EXPECT_LT(test::TranslationAngle(pose.translation, scene.cam2_from_cam1.translation),
              5 * tolerance);
    EXPECT_NEAR(pose.translation.norm(), 1.0, 1e-12);
  }
  std::vector<int> few = {0, 1, 2};
  const TwoViewScene scene = MakeScene(32, 20, 0.0, 0.0, false);
  Rigid3d pose = scene.cam2_from_cam1;
  EXPECT_EQ(RefineRelativePose(scene.bearings1.data(), scene.bearings2.data(), 20, &few, 10, &pose),
            -1);
}

// The refiner's analytic derivative of EpipolarSine (rebuilt as in essential.cc) against
// central differences through the same perturbation (R <- Exp(omega) R, t <- normalize(t + B d)).
TEST(RefineRelativePose, EpipolarSineJacobianMatchesCentralDifferences) {
  const TwoViewScene scene = MakeScene(33, 10, 1e-3, 0.0, false);
  const Rigid3d pose(scene.cam2_from_cam1.rotation, scene.cam2_from_cam1.translation.normalized());
  const Eigen::Vector3d& t = pose.translation;
  const Eigen::Vector3d helper =
      std::abs(t.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  Eigen::Matrix<double, 3, 2> B;
  B.col(0) = (helper - t.dot(helper) * t).normalized();
  B.col(1) = t.cross(B.col(0));
  for (int i = 0; i < 10; ++i) {
    const Eigen::Vector3d& x1 = scene.bearings1[i];
    const Eigen::Vector3d& x2 = scene.bearings2[i];
    const Eigen::Vector3d a = pose.rotation * x1;
    const Eigen::Vector3d n = t.cross(a);
    const double r = x2.dot(n) / n.norm();
    const Eigen::RowVector3d J_r_n = (x2 - r * n / n.norm()).transpose() / n.norm();
    Eigen::Matrix<double, 1, 5> J;
    J.leftCols<3>() = -J_r_n * SkewSymmetric(t) * SkewSymmetric(a);
    J.rightCols<2>() = -J_r_n * SkewSymmetric(a) * B;
    const double h = 1e-6;
    for (int k = 0; k < 5; ++k) {
      Eigen::Matrix<double, 5, 1> delta = Eigen::Matrix<double, 5, 1>::Zero();
      delta(k) = h;
      auto moved = [&](const Eigen::Matrix<double, 5, 1>& d) {
        // First order in d, the normalization of t does not change the derivative.
        return Rigid3d(ExpSO3(d.head<3>()) * pose.rotation, (t + B * d.tail<2>()).normalized());
      };
      const double numeric = (EpipolarSine(moved(delta), x1, x2) -
                              EpipolarSine(moved(-delta), x1, x2)) / (2 * h);
      EXPECT_NEAR(J(k), numeric, 1e-7 * (1.0 + std::abs(numeric))) << "pair " << i << " k " << k;
    }
  }
}

}  // namespace
}  // namespace lcv::slam
