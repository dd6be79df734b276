#include "slam/optimize/rigid_stereo_ba.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "slam/geometry/so3.h"
#include "slam/optimize/ceres_costs.h"
#include "slam/optimize/residuals.h"
#include "tests/slam/optimize/optimize_test_util.h"

namespace lcv::slam {
namespace {

using testing::NumericJacobian;
using testing::RandomPose;
using testing::RelativeError;
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
    const Eigen::Vector3d in_reference((2.0 * unit(rng) - 1.0) * 2.0, (2.0 * unit(rng) - 1.0) * 1.0,
                                       4.0 + 6.0 * unit(rng));
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
      const Eigen::Vector2d px = *camera->Project(views[i].cam_from_reference * in_reference);
      obs.observed_px =
          px + (outlier ? Eigen::Vector2d(25.0, -20.0) : Eigen::Vector2d(noise(rng), noise(rng)));
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

TEST(ScaledOffsetLineCost, TangentJacobiansMatchCentralDifferences) {
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (const CameraModel model : testing::AllCameraModels()) {
    const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(model));
    internal::PoseManifold pose_manifold;
    for (int trial = 0; trial < 4; ++trial) {
      const Rigid3d reference_from_world = RandomPose(&rng, 0.5, 1.0);
      const Rigid3d cam_from_reference = RandomPose(&rng, 0.1, 0.5);
      const Eigen::Vector3d in_reference(0.5 * unit(rng), 0.3 * unit(rng), 4.0 + unit(rng));
      Eigen::Vector3d point = reference_from_world.Inverse() * in_reference;
      const Eigen::Vector3d d = UniformUnitVector(unit(rng), unit(rng));
      const Line3d line(point + Eigen::Vector3d(0.05, -0.02, 0.03), d);
      const Eigen::Matrix3d S =
          SqrtInformation(LineInformation(d, 0.01 * Eigen::Matrix3d::Identity()));
      const internal::ScaledOffsetLineCost cost(camera.get(), Eigen::Vector2d(300, 170), 0.7, line,
                                                S, 2.0, cam_from_reference);
      double pose[7];
      internal::PoseToParameters(reference_from_world, pose);
      double scale = 0.8 + 0.4 * unit(rng);
      double* params[3] = {pose, point.data(), &scale};
      Eigen::Matrix<double, 5, 1> r;
      Eigen::Matrix<double, 5, 7, Eigen::RowMajor> J_pose;
      Eigen::Matrix<double, 5, 3, Eigen::RowMajor> J_point;
      Eigen::Matrix<double, 5, 1> J_scale;
      double* jacobians[3] = {J_pose.data(), J_point.data(), J_scale.data()};
      ASSERT_TRUE(cost.Evaluate(params, r.data(), jacobians));
      Eigen::Matrix<double, 7, 6, Eigen::RowMajor> plus_pose;
      pose_manifold.PlusJacobian(pose, plus_pose.data());
      auto evaluate = [&](const double* p, const double* pt, const double* g) {
        const double* ps[3] = {p, pt, g};
        Eigen::Matrix<double, 5, 1> out;
        EXPECT_TRUE(cost.Evaluate(ps, out.data(), nullptr));
        return out;
      };
      const auto J_pose_numeric = NumericJacobian<5, 6>([&](const Vector6d& delta) {
        double moved[7];
        pose_manifold.Plus(pose, delta.data(), moved);
        return evaluate(moved, point.data(), &scale);
      });
      const auto J_point_numeric = NumericJacobian<5, 3>([&](const Eigen::Vector3d& delta) {
        const Eigen::Vector3d moved = point + delta;
        return evaluate(pose, moved.data(), &scale);
      });
      const auto J_scale_numeric =
          NumericJacobian<5, 1>([&](const Eigen::Matrix<double, 1, 1>& delta) {
            const double moved = scale + delta(0);
            return evaluate(pose, point.data(), &moved);
          });
      constexpr double kTolerance = 1e-5;
      EXPECT_LT(RelativeError(Eigen::Matrix<double, 5, 6>(J_pose * plus_pose), J_pose_numeric),
                kTolerance)
          << CameraModelName(model);
      EXPECT_LT(RelativeError(Eigen::Matrix<double, 5, 3>(J_point), J_point_numeric), kTolerance)
          << CameraModelName(model);
      EXPECT_LT(RelativeError(J_scale, J_scale_numeric), kTolerance) << CameraModelName(model);
    }
  }
}

TEST(SolveRigidStereoBA, RecoversTheGroupScaleWhenFreed) {
  const unsigned seed = 17;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.7);
  const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(CameraModel::kPerspective));
  const Rigid3d true_reference_from_world = RandomPose(&rng, 0.5, 2.0);
  // Baselines 0.5 m and 1 m, handed to the BA 4% too short.
  constexpr double kTrueGroupScale = 1.04;
  std::vector<RigidStereoView> views(3), true_views(3);
  for (int i = 0; i < 3; ++i) {
    true_views[i].camera = views[i].camera = camera.get();
    true_views[i].cam_from_reference = i == 0
                                           ? Rigid3d()
                                           : Rigid3d(ExpSO3(Eigen::Vector3d(0.0, 0.03 * i, 0.0)),
                                                     Eigen::Vector3d(-0.5 * i, 0.05 * i, 0.1 * i));
    views[i].cam_from_reference = true_views[i].cam_from_reference;
    views[i].cam_from_reference.translation /= kTrueGroupScale;
  }
  const Rigid3d world_from_reference = true_reference_from_world.Inverse();
  const Eigen::Matrix3d covariance = 0.03 * 0.03 * Eigen::Matrix3d::Identity();
  std::vector<RigidStereoLine> lines;
  std::vector<RigidStereoObservation> observations;
  for (int k = 0; k < 150; ++k) {
    const Eigen::Vector3d in_reference((2.0 * unit(rng) - 1.0) * 3.0, (2.0 * unit(rng) - 1.0) * 1.5,
                                       4.0 + 8.0 * unit(rng));
    const Eigen::Vector3d hidden = world_from_reference * in_reference;
    const Eigen::Vector3d d = UniformUnitVector(unit(rng), unit(rng));
    RigidStereoLine line;
    line.line = Line3d(hidden + (2.0 * unit(rng) - 1.0) * d, d);
    line.information = LineInformation(d, covariance);
    line.restored_point = line.line.Project(hidden + 0.05 * in_reference.norm() * d);
    lines.push_back(line);
    for (int i = 0; i < 3; ++i) {
      const auto px = camera->Project(true_views[i].cam_from_reference * in_reference);
      if (!px || !camera->InImage(*px)) continue;
      RigidStereoObservation obs;
      obs.view = i;
      obs.line = k;
      obs.observed_px = *px + Eigen::Vector2d(noise(rng), noise(rng));
      observations.push_back(obs);
    }
  }
  Rigid3d reference = RandomPose(&rng, 0.01, 0.05) * true_reference_from_world;
  double group_scale = 1.0;
  const BundleReport report =
      SolveRigidStereoBA(BundleOptions(), views, &reference, &lines, &observations, &group_scale);
  ASSERT_TRUE(report.success) << report.message;
  EXPECT_NEAR(group_scale, kTrueGroupScale, 0.004) << "seed " << seed;
  EXPECT_LT((reference.Center() - true_reference_from_world.Center()).norm(), 0.03);
  EXPECT_LT(AngularDistance(reference.rotation, true_reference_from_world.rotation), 3e-3);

  // The same with the scale held: the short baselines cannot be explained as well.
  Rigid3d held = RandomPose(&rng, 0.01, 0.05) * true_reference_from_world;
  std::vector<RigidStereoObservation> held_observations = observations;
  for (RigidStereoObservation& obs : held_observations) obs.outlier = false;
  const BundleReport held_report =
      SolveRigidStereoBA(BundleOptions(), views, &held, &lines, &held_observations);
  ASSERT_TRUE(held_report.success);
  EXPECT_GT(held_report.final_cost, report.final_cost);
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
