#include "slam/optimize/rigid_stereo_ba.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "slam/geometry/so3.h"
#include "slam/optimize/residuals.h"
#include "tests/slam/optimize/optimize_test_util.h"

namespace lcv::slam {
namespace {

using testing::RandomPose;
using testing::TestCameraParams;

TEST(SolveRigidStereoBA, RecoversTheReferencePoseFromLinesSeenByARigidGroup) {
  const unsigned seed = 9;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.7);
  const std::unique_ptr<Camera> camera =
      MakeCamera(TestCameraParams(CameraModel::kEquirectangular));
  const Rigid3d true_reference_from_world = RandomPose(&rng, 0.5, 2.0);
  // Three keyframes: the current one and two neighbours 0.5 m and 1 m away (Delta P constant).
  std::vector<RigidStereoView> views(3);
  for (int i = 0; i < 3; ++i) {
    views[i].camera = camera.get();
    views[i].cam_from_reference =
        i == 0 ? Rigid3d()
               : Rigid3d(ExpSO3(Eigen::Vector3d(0.0, 0.05 * i, 0.0)),
                         Eigen::Vector3d(-0.5 * i, 0.0, 0.1 * i));
  }
  const Rigid3d world_from_reference = true_reference_from_world.Inverse();
  std::vector<RigidStereoLine> lines;
  std::vector<RigidStereoObservation> observations;
  std::vector<char> is_outlier;
  const Eigen::Matrix3d covariance = 0.03 * 0.03 * Eigen::Matrix3d::Identity();
  for (int k = 0; k < 120; ++k) {
    const Eigen::Vector3d bearing = UniformUnitVector(0.15 + 0.7 * unit(rng), unit(rng));
    const Eigen::Vector3d hidden = world_from_reference * ((3.0 + 10.0 * unit(rng)) * bearing);
    const Eigen::Vector3d d = UniformUnitVector(unit(rng), unit(rng));
    RigidStereoLine line;
    line.line = Line3d(hidden + (2.0 * unit(rng) - 1.0) * d, d);
    line.information = LineInformation(d, covariance);
    line.restored_point = hidden + 0.1 * Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    lines.push_back(line);
    for (int i = 0; i < 3; ++i) {
      const Rigid3d cam_from_world = views[i].cam_from_reference * true_reference_from_world;
      RigidStereoObservation obs;
      obs.view = i;
      obs.line = k;
      const bool outlier = unit(rng) < 0.15;
      obs.observed_px = outlier ? Eigen::Vector2d(unit(rng) * camera->cols(),
                                                  unit(rng) * camera->rows())
                                : Eigen::Vector2d(*camera->Project(cam_from_world * hidden) +
                                                  Eigen::Vector2d(noise(rng), noise(rng)));
      observations.push_back(obs);
      is_outlier.push_back(outlier);
    }
  }
  Rigid3d reference = RandomPose(&rng, 0.02, 0.1) * true_reference_from_world;
  const double initial_error = (reference.Center() - true_reference_from_world.Center()).norm();
  const BundleReport report =
      SolveRigidStereoBA(BundleOptions(), views, &reference, &lines, &observations);
  ASSERT_TRUE(report.success) << report.message;
  const double error = (reference.Center() - true_reference_from_world.Center()).norm();
  EXPECT_LT(error, 0.03) << "seed " << seed << ", initial " << initial_error;
  EXPECT_LT(AngularDistance(reference.rotation, true_reference_from_world.rotation), 3e-3);
  int wrong = 0;
  for (size_t i = 0; i < observations.size(); ++i) {
    wrong += observations[i].outlier != static_cast<bool>(is_outlier[i]);
  }
  EXPECT_LT(wrong, 0.1 * observations.size());
}

TEST(SolveRigidStereoBA, FixedPointsStayPutAndPinThePose) {
  const unsigned seed = 13;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.7);
  const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(CameraModel::kPerspective));
  const Rigid3d true_reference_from_world = RandomPose(&rng, 0.5, 2.0);
  std::vector<RigidStereoView> views(2);
  for (int i = 0; i < 2; ++i) {
    views[i].camera = camera.get();
    views[i].cam_from_reference =
        i == 0 ? Rigid3d() : Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-0.5, 0, 0));
  }
  const Rigid3d world_from_reference = true_reference_from_world.Inverse();
  std::vector<RigidStereoLine> points;
  std::vector<RigidStereoObservation> observations;
  std::vector<char> is_outlier;
  for (int k = 0; k < 60; ++k) {
    const Eigen::Vector3d in_reference((2.0 * unit(rng) - 1.0) * 2.0,
                                       (2.0 * unit(rng) - 1.0) * 1.0, 4.0 + 6.0 * unit(rng));
    RigidStereoLine point;
    point.restored_point = world_from_reference * in_reference;
    point.line = Line3d(point.restored_point, Eigen::Vector3d::UnitX());
    point.fixed = true;
    points.push_back(point);
    for (int i = 0; i < 2; ++i) {
      RigidStereoObservation obs;
      obs.view = i;
      obs.line = k;
      const bool outlier = unit(rng) < 0.1;
      const Eigen::Vector2d px =
          *camera->Project(views[i].cam_from_reference * in_reference);
      obs.observed_px = px + (outlier ? Eigen::Vector2d(25.0, -20.0)
                                      : Eigen::Vector2d(noise(rng), noise(rng)));
      observations.push_back(obs);
      is_outlier.push_back(outlier);
    }
  }
  const std::vector<RigidStereoLine> before = points;
  Rigid3d reference = RandomPose(&rng, 0.03, 0.1) * true_reference_from_world;
  const BundleReport report =
      SolveRigidStereoBA(BundleOptions(), views, &reference, &points, &observations);
  ASSERT_TRUE(report.success) << report.message;
  EXPECT_LT((reference.Center() - true_reference_from_world.Center()).norm(), 0.03);
  EXPECT_LT(AngularDistance(reference.rotation, true_reference_from_world.rotation), 3e-3);
  for (size_t k = 0; k < points.size(); ++k) {
    EXPECT_EQ(points[k].restored_point, before[k].restored_point) << "fixed X' moved";
  }
  int wrong = 0;
  for (size_t i = 0; i < observations.size(); ++i) {
    wrong += observations[i].outlier != static_cast<bool>(is_outlier[i]);
  }
  EXPECT_LE(wrong, 3) << "seed " << seed;
}

TEST(SolveRigidStereoBA, OutOfRangeObservationIsABug) {
  const std::unique_ptr<Camera> camera =
      MakeCamera(TestCameraParams(CameraModel::kPerspective));
  std::vector<RigidStereoView> views(1);
  views[0].camera = camera.get();
  std::vector<RigidStereoLine> lines(1);
  std::vector<RigidStereoObservation> observations(1);
  observations[0].view = 0;
  observations[0].line = 3;
  Rigid3d pose;
  EXPECT_THROW(SolveRigidStereoBA(BundleOptions(), views, &pose, &lines, &observations),
               std::logic_error);
}

}  // namespace
}  // namespace lcv::slam
