#include "slam/optimize/sim3_reprojection.h"

#include <cmath>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>

#include "slam/solve/ransac.h"
#include "tests/slam/optimize/optimize_test_util.h"

namespace lcv::slam {
namespace {

using testing::NumericJacobian;
using testing::RelativeError;

// Two cameras 1.5 m apart looking at the same cloud; B's side of the map has a different scale:
// a_from_b = (scale 1.3, rotation, translation). Correspondences with pixel noise and a share of
// outliers (B's point replaced by another one of the cloud).
struct Sim3Data {
  std::unique_ptr<Camera> camera_a, camera_b;
  Sim3d a_from_b;
  std::vector<Sim3Correspondence> correspondences;
  std::vector<char> is_outlier;
};

Sim3Data MakeData(CameraModel model, int count, double outlier_ratio, double pixel_sigma,
                  unsigned seed) {
  std::mt19937 rng(seed);
  Sim3Data d;
  d.camera_a = MakeCamera(testing::TestCameraParams(model));
  d.camera_b = MakeCamera(testing::TestCameraParams(model));
  const Rigid3d a_from_world = testing::RandomPose(&rng, 0.05, 0.1);
  const Rigid3d b_from_world =
      Rigid3d(ExpSO3(Eigen::Vector3d(0.0, 0.15, 0.02)), Eigen::Vector3d(-1.5, 0.1, 0.2)) *
      a_from_world;
  const double b_scale = 1.0 / 1.3;  // B's map units per metre
  d.a_from_b = Sim3d(a_from_world * b_from_world.Inverse()) *
               Sim3d(1.0 / b_scale, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero());
  std::uniform_real_distribution<double> ux(-3.0, 3.0), uy(-1.5, 1.5), uz(4.0, 9.0);
  std::normal_distribution<double> pixel(0.0, pixel_sigma);
  std::bernoulli_distribution outlier(outlier_ratio);
  std::vector<Eigen::Vector3d> world;
  while (static_cast<int>(world.size()) < count) {
    const Eigen::Vector3d p = a_from_world.Inverse() * Eigen::Vector3d(ux(rng), uy(rng), uz(rng));
    const auto pa = d.camera_a->Project(a_from_world * p);
    const auto pb = d.camera_b->Project(b_from_world * p);
    if (pa && pb && d.camera_a->InImage(*pa) && d.camera_b->InImage(*pb)) world.push_back(p);
  }
  for (int i = 0; i < count; ++i) {
    const bool bad = outlier(rng);
    const Eigen::Vector3d& p_b = bad ? world[(i + count / 2) % count] : world[i];
    Sim3Correspondence c;
    c.point_in_a = a_from_world * world[i];
    c.point_in_b = b_scale * (b_from_world * p_b);
    c.px_a = *d.camera_a->Project(c.point_in_a) + Eigen::Vector2d(pixel(rng), pixel(rng));
    c.px_b = *d.camera_b->Project(b_from_world * p_b) + Eigen::Vector2d(pixel(rng), pixel(rng));
    c.information_a = 1.0;
    c.information_b = 1.0 / (1.2 * 1.2);
    d.correspondences.push_back(c);
    d.is_outlier.push_back(bad);
  }
  return d;
}

double RotationErrorDeg(const Sim3d& a, const Sim3d& b) {
  return AngularDistance(a.rotation, b.rotation) * 180.0 / M_PI;
}

TEST(Sim3Reprojection, ZeroResidualAtTheTruthAndJacobianMatchesNumeric) {
  for (const CameraModel model : testing::AllCameraModels()) {
    const Sim3Data d = MakeData(model, 20, 0.0, 0.0, 3);
    for (const Sim3Correspondence& c : d.correspondences) {
      Eigen::Vector4d r;
      ASSERT_TRUE(Sim3ReprojectionResidual(*d.camera_a, *d.camera_b, c, d.a_from_b, &r));
      EXPECT_LT(r.norm(), 1e-8);
      // Jacobian at a perturbed model (non-zero residual), through S <- Exp(delta) S.
      Vector7d offset;
      offset << 0.02, -0.03, 0.01, 0.01, -0.02, 0.015, 0.05;
      const Sim3d model_at = Sim3d::Exp(offset) * d.a_from_b;
      Eigen::Matrix<double, 4, 7> J;
      ASSERT_TRUE(Sim3ReprojectionResidual(*d.camera_a, *d.camera_b, c, model_at, &r, &J));
      const auto numeric = NumericJacobian<4, 7>([&](const Vector7d& delta) {
        Eigen::Vector4d out;
        Sim3ReprojectionResidual(*d.camera_a, *d.camera_b, c, Sim3d::Exp(delta) * model_at, &out);
        return out;
      });
      EXPECT_LT(RelativeError(J, numeric), 1e-5) << "model " << static_cast<int>(model);
    }
  }
}

TEST(Sim3Reprojection, RansacAndRefinementRecoverTheSimilarityWithOutliers) {
  const unsigned seed = 8;
  const Sim3Data d = MakeData(CameraModel::kPerspective, 120, 0.4, 0.7, seed);
  const Sim3ReprojectionEstimator estimator(*d.camera_a, *d.camera_b, d.correspondences);
  RansacOptions options;
  options.max_error = std::sqrt(9.21);
  options.max_num_trials = 300;
  options.confidence = 0.99;
  options.random_seed = seed;
  const RansacReport<Sim3d> report = Ransac(options, estimator);
  ASSERT_TRUE(report.success) << "seed " << seed;
  Sim3d model = report.model;
  const Sim3RefineReport refined =
      RefineSim3Reprojection(*d.camera_a, *d.camera_b, d.correspondences, {}, &model);
  int true_inliers = 0, wrong = 0;
  for (size_t i = 0; i < d.correspondences.size(); ++i) {
    true_inliers += !d.is_outlier[i];
    wrong += refined.inlier_mask[i] == d.is_outlier[i];
  }
  EXPECT_LE(wrong, 2) << "seed " << seed;
  EXPECT_GE(refined.num_inliers, true_inliers - 2);
  EXPECT_LT(RotationErrorDeg(model, d.a_from_b), 0.1);
  EXPECT_LT(std::abs(model.scale / d.a_from_b.scale - 1.0), 0.01);
  EXPECT_LT((model.translation - d.a_from_b.translation).norm(), 0.03);
}

TEST(Sim3Reprojection, RefinementConvergesFromAPerturbedStart) {
  const Sim3Data d = MakeData(CameraModel::kFisheye, 60, 0.0, 0.3, 9);
  Vector7d offset;
  offset << 0.05, -0.04, 0.03, 0.01, -0.01, 0.02, 0.03;
  Sim3d model = Sim3d::Exp(offset) * d.a_from_b;
  Sim3RefineOptions options;
  options.chi2_threshold = 1e6;  // no outliers here; start errors are tens of pixels
  options.iterations = 10;
  const Sim3RefineReport refined =
      RefineSim3Reprojection(*d.camera_a, *d.camera_b, d.correspondences, options, &model);
  EXPECT_EQ(refined.num_inliers, 60);
  // The noise floor: the same refinement started at the truth.
  Sim3d from_truth = d.a_from_b;
  RefineSim3Reprojection(*d.camera_a, *d.camera_b, d.correspondences, options, &from_truth);
  std::printf("rotation error %.4f deg (from truth %.4f), scale %.5f vs %.5f\n",
              RotationErrorDeg(model, d.a_from_b), RotationErrorDeg(from_truth, d.a_from_b),
              model.scale, d.a_from_b.scale);
  EXPECT_LT(RotationErrorDeg(model, from_truth), 0.01);
  EXPECT_LT(RotationErrorDeg(model, d.a_from_b), 0.1);
  EXPECT_LT(std::abs(std::log(model.scale / d.a_from_b.scale)), 0.005);
}

TEST(Sim3Reprojection, DegenerateSampleGivesNoModel) {
  const Sim3Data d = MakeData(CameraModel::kPerspective, 10, 0.0, 0.0, 10);
  std::vector<Sim3Correspondence> same(3, d.correspondences[0]);
  const Sim3ReprojectionEstimator estimator(*d.camera_a, *d.camera_b, same);
  std::vector<Sim3d> models;
  estimator.Estimate({0, 1, 2}, &models);
  EXPECT_TRUE(models.empty());
}

}  // namespace
}  // namespace lcv::slam
