#include "slam/optimize/residuals.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "slam/geometry/line3.h"
#include "slam/optimize/ceres_costs.h"
#include "tests/slam/optimize/optimize_test_util.h"

namespace lcv::slam {
namespace {

using testing::AllCameraModels;
using testing::NumericJacobian;
using testing::RandomPose;
using testing::RelativeError;
using testing::TestCameraParams;

constexpr double kTolerance = 1e-6;

// A point the model images well: inside a cone around the optical axis (any direction for
// equirectangular, whose poles and seam are avoided).
Eigen::Vector3d RandomVisiblePoint(CameraModel model, std::mt19937* rng) {
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::uniform_real_distribution<double> depth(2.0, 10.0);
  if (model == CameraModel::kEquirectangular) {
    const double lon = 2.8 * uniform(*rng);
    const double lat = 1.2 * uniform(*rng);
    const Eigen::Vector3d bearing(std::cos(lat) * std::sin(lon), std::sin(lat),
                                  std::cos(lat) * std::cos(lon));
    return depth(*rng) * bearing;
  }
  const double spread = model == CameraModel::kFisheye ? 0.9 : 0.5;
  return depth(*rng) * Eigen::Vector3d(spread * uniform(*rng), 0.5 * spread * uniform(*rng), 1.0);
}

TEST(ReprojectionResidual, JacobiansMatchCentralDifferencesForEveryModel) {
  std::mt19937 rng(7);
  for (const CameraModel model : AllCameraModels()) {
    SCOPED_TRACE(CameraModelName(model));
    const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(model));
    for (int trial = 0; trial < 20; ++trial) {
      const Rigid3d cam_from_world = RandomPose(&rng, 1.0, 3.0);
      const Eigen::Vector3d p_in_world =
          cam_from_world.Inverse() * RandomVisiblePoint(model, &rng);
      const Eigen::Vector2d observed(300.0, 200.0);
      Eigen::Vector2d r;
      Matrix26d J_pose;
      Matrix23d J_point;
      ASSERT_TRUE(ReprojectionResidual(*camera, cam_from_world, p_in_world, observed, &r,
                                       &J_pose, &J_point));
      const Eigen::Matrix<double, 2, 6> J_pose_numeric =
          NumericJacobian<2, 6>([&](const Vector6d& delta) {
            Eigen::Vector2d out;
            EXPECT_TRUE(ReprojectionResidual(*camera, Rigid3d::Exp(delta) * cam_from_world,
                                             p_in_world, observed, &out));
            return out;
          });
      const Matrix23d J_point_numeric = NumericJacobian<2, 3>([&](const Eigen::Vector3d& delta) {
        Eigen::Vector2d out;
        EXPECT_TRUE(
            ReprojectionResidual(*camera, cam_from_world, p_in_world + delta, observed, &out));
        return out;
      });
      EXPECT_LT(RelativeError(J_pose, J_pose_numeric), kTolerance) << "trial " << trial;
      EXPECT_LT(RelativeError(J_point, J_point_numeric), kTolerance) << "trial " << trial;
      // The residual itself is the projection minus the observation.
      EXPECT_LT((r + observed - *camera->Project(cam_from_world * p_in_world)).norm(), 1e-9);
    }
  }
}

TEST(ReprojectionResidual, PointBehindPerspectiveCameraIsRejected) {
  const std::unique_ptr<Camera> camera =
      MakeCamera(TestCameraParams(CameraModel::kPerspective));
  Eigen::Vector2d r(-1.0, -1.0);
  EXPECT_FALSE(ReprojectionResidual(*camera, Rigid3d(), Eigen::Vector3d(0.1, 0.2, -3.0),
                                    Eigen::Vector2d(1.0, 2.0), &r));
  EXPECT_EQ(r, Eigen::Vector2d(-1.0, -1.0));  // untouched
}

Eigen::Matrix3d RandomCovariance(std::mt19937* rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::Matrix3d A;
  for (int i = 0; i < 9; ++i) A(i) = normal(*rng);
  return 0.01 * (A * A.transpose() + 0.5 * Eigen::Matrix3d::Identity());
}

Line3d RandomLine(std::mt19937* rng) {
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> normal(0.0, 2.0);
  return Line3d(Eigen::Vector3d(normal(*rng), normal(*rng), normal(*rng) + 6.0),
                UniformUnitVector(uniform(*rng), uniform(*rng)));
}

TEST(SqrtInformation, SquaresBackAndKeepsTheNullSpace) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 10; ++trial) {
    const Line3d line = RandomLine(&rng);
    const Eigen::Matrix3d information = LineInformation(line.direction, RandomCovariance(&rng));
    const Eigen::Matrix3d S = SqrtInformation(information);
    EXPECT_LT(RelativeError(S * S, information), 1e-9);
    EXPECT_LT((S - S.transpose()).norm(), 1e-12 * S.norm());
    EXPECT_LT((S * line.direction).norm(), 1e-6 * S.norm());
  }
}

TEST(PointToLineResidual, EqualsThePapersTermAndItsJacobiansMatch) {
  std::mt19937 rng(11);
  std::normal_distribution<double> normal(0.0, 0.3);
  for (int trial = 0; trial < 20; ++trial) {
    const Line3d line = RandomLine(&rng);
    const Eigen::Matrix3d information = LineInformation(line.direction, RandomCovariance(&rng));
    const Eigen::Matrix3d S = SqrtInformation(information);
    const Eigen::Vector3d x =
        line.PointAt(3.0 * normal(rng)) + Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    Eigen::Vector3d r;
    Eigen::Matrix3d J_point;
    Matrix34d J_line;
    PointToLineResidual(x, line, S, &r, &J_point, &J_line);
    // ||X' - p_L||^2 under Omega_L (paper eq. 3), independent of the anchor's position on L.
    const Eigen::Vector3d offset = x - line.anchor;
    EXPECT_NEAR(r.squaredNorm(), offset.dot(information * offset),
                1e-9 * (1.0 + r.squaredNorm()));
    Eigen::Vector3d r_shifted;
    PointToLineResidual(x, Line3d(line.PointAt(5.0), line.direction), S, &r_shifted);
    EXPECT_LT((r_shifted - r).norm(), 1e-9 * (1.0 + r.norm()));

    const Eigen::Matrix3d J_point_numeric =
        NumericJacobian<3, 3>([&](const Eigen::Vector3d& delta) {
          Eigen::Vector3d out;
          PointToLineResidual(x + delta, line, S, &out);
          return out;
        });
    const Matrix34d J_line_numeric = NumericJacobian<3, 4>([&](const Eigen::Vector4d& delta) {
      Eigen::Vector3d out;
      PointToLineResidual(x, RetractLine(line, delta), S, &out);
      return out;
    });
    EXPECT_LT(RelativeError(J_point, J_point_numeric), kTolerance);
    EXPECT_LT(RelativeError(J_line, J_line_numeric), kTolerance);
  }
}

TEST(RetractLine, KeepsUnitDirectionAndMovesTheAnchorOrthogonally) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 10; ++trial) {
    const Line3d line = RandomLine(&rng);
    const Matrix32d B = OrthonormalComplement(line.direction);
    EXPECT_LT((B.transpose() * B - Eigen::Matrix2d::Identity()).norm(), 1e-12);
    EXPECT_LT((B.col(0).cross(B.col(1)) - line.direction).norm(), 1e-12);
    const Line3d moved = RetractLine(line, Eigen::Vector4d(0.3, -0.2, 0.1, 0.05));
    EXPECT_NEAR(moved.direction.norm(), 1.0, 1e-12);
    EXPECT_NEAR((moved.anchor - line.anchor).dot(line.direction), 0.0, 1e-12);
    const Line3d same = RetractLine(line, Eigen::Vector4d::Zero());
    EXPECT_LT((same.anchor - line.anchor).norm() + (same.direction - line.direction).norm(),
              1e-15);
  }
}

TEST(VirtualObservationResidual, MatchesThePapersErrorAndItsJacobiansMatch) {
  std::mt19937 rng(13);
  for (int trial = 0; trial < 20; ++trial) {
    const Rigid3d cam_from_world = RandomPose(&rng, 1.0, 2.0);
    const Line3d line = RandomLine(&rng);
    // n_v from a slightly different (initial) line and pose.
    const Line3d initial = RetractLine(line, Eigen::Vector4d(0.05, -0.03, 0.02, 0.01));
    const Eigen::Vector3d n_v = LinePlaneNormal(cam_from_world, initial);
    ASSERT_NEAR(n_v.norm(), 1.0, 1e-12);
    Eigen::Vector2d r;
    Matrix26d J_pose;
    Matrix24d J_line;
    ASSERT_TRUE(VirtualObservationResidual(cam_from_world, line, n_v, &r, &J_pose, &J_line));
    // |r|^2 = sin^2(theta) and the paper's (1 - cos theta)^2, theta the angle between normals.
    const double cos_theta = LinePlaneNormal(cam_from_world, line).dot(n_v);
    EXPECT_NEAR(r.squaredNorm(), 1.0 - cos_theta * cos_theta, 1e-12);
    EXPECT_NEAR(VirtualObservationError(cam_from_world, line, n_v),
                (1.0 - cos_theta) * (1.0 - cos_theta), 1e-15);

    const Matrix26d J_pose_numeric = NumericJacobian<2, 6>([&](const Vector6d& delta) {
      Eigen::Vector2d out;
      EXPECT_TRUE(
          VirtualObservationResidual(Rigid3d::Exp(delta) * cam_from_world, line, n_v, &out));
      return out;
    });
    const Matrix24d J_line_numeric = NumericJacobian<2, 4>([&](const Eigen::Vector4d& delta) {
      Eigen::Vector2d out;
      EXPECT_TRUE(VirtualObservationResidual(cam_from_world, RetractLine(line, delta), n_v, &out));
      return out;
    });
    EXPECT_LT(RelativeError(J_pose, J_pose_numeric), kTolerance) << "trial " << trial;
    EXPECT_LT(RelativeError(J_line, J_line_numeric), kTolerance) << "trial " << trial;
  }
}

TEST(VirtualObservationResidual, ZeroAtTheInitialLineAndUndefinedThroughTheCentre) {
  const Rigid3d cam_from_world(ExpSO3(Eigen::Vector3d(0.1, -0.2, 0.3)),
                               Eigen::Vector3d(0.5, 0.1, -0.2));
  const Line3d line(Eigen::Vector3d(1.0, 2.0, 8.0), Eigen::Vector3d(0.6, 0.0, 0.8));
  const Eigen::Vector3d n_v = LinePlaneNormal(cam_from_world, line);
  Eigen::Vector2d r;
  ASSERT_TRUE(VirtualObservationResidual(cam_from_world, line, n_v, &r));
  EXPECT_LT(r.norm(), 1e-15);
  EXPECT_EQ(VirtualObservationError(cam_from_world, line, n_v), 0.0);
  // A line through the camera centre spans no plane.
  const Line3d through_centre(cam_from_world.Center(), Eigen::Vector3d::UnitX());
  EXPECT_EQ(LinePlaneNormal(cam_from_world, through_centre), Eigen::Vector3d::Zero());
  EXPECT_FALSE(VirtualObservationResidual(cam_from_world, through_centre, n_v, &r));
}

TEST(AdjointSE3, ConjugatesTheExponential) {
  std::mt19937 rng(17);
  const Rigid3d T = RandomPose(&rng, 1.0, 2.0);
  Vector6d delta;
  delta << 0.1, -0.2, 0.3, 0.05, -0.02, 0.04;
  const Rigid3d lhs = Rigid3d::Exp(AdjointSE3(T) * delta);
  const Rigid3d rhs = T * Rigid3d::Exp(delta) * T.Inverse();
  EXPECT_LT((lhs.ToMatrix() - rhs.ToMatrix()).norm(), 1e-12);
}

// The Ceres cost functions: their lifted Jacobians times the manifold's PlusJacobian are the
// tangent Jacobians, checked by central differences through the manifolds' Plus.
TEST(CeresCosts, TangentJacobiansMatchCentralDifferencesThroughTheManifolds) {
  std::mt19937 rng(19);
  const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(CameraModel::kFisheye));
  internal::PoseManifold pose_manifold;
  internal::LineManifold line_manifold;
  for (int trial = 0; trial < 5; ++trial) {
    const Rigid3d cam_from_world = RandomPose(&rng, 0.5, 1.0);
    const Eigen::Vector3d x =
        cam_from_world.Inverse() * RandomVisiblePoint(CameraModel::kFisheye, &rng);
    const Line3d line(x + Eigen::Vector3d(0.05, -0.02, 0.03), Eigen::Vector3d(0, 0.6, 0.8));
    const Eigen::Matrix3d S =
        SqrtInformation(LineInformation(line.direction, 0.01 * Eigen::Matrix3d::Identity()));
    double pose[7], line_params[6];
    internal::PoseToParameters(cam_from_world, pose);
    internal::LineToParameters(line, line_params);
    Eigen::Vector3d point = x;
    const internal::FreeLineObservationCost cost(camera.get(), Eigen::Vector2d(310, 170), 0.7,
                                                 S, 2.0);
    double* params[3] = {pose, point.data(), line_params};
    Eigen::Matrix<double, 5, 1> r;
    Eigen::Matrix<double, 5, 7, Eigen::RowMajor> J_pose;
    Eigen::Matrix<double, 5, 3, Eigen::RowMajor> J_point;
    Eigen::Matrix<double, 5, 6, Eigen::RowMajor> J_line;
    double* jacobians[3] = {J_pose.data(), J_point.data(), J_line.data()};
    ASSERT_TRUE(cost.Evaluate(params, r.data(), jacobians));
    Eigen::Matrix<double, 7, 6, Eigen::RowMajor> plus_pose;
    Eigen::Matrix<double, 6, 4, Eigen::RowMajor> plus_line;
    pose_manifold.PlusJacobian(pose, plus_pose.data());
    line_manifold.PlusJacobian(line_params, plus_line.data());

    auto evaluate = [&](const double* p, const double* pt, const double* l) {
      const double* ps[3] = {p, pt, l};
      Eigen::Matrix<double, 5, 1> out;
      EXPECT_TRUE(cost.Evaluate(ps, out.data(), nullptr));
      return out;
    };
    const auto J_pose_numeric = NumericJacobian<5, 6>([&](const Vector6d& delta) {
      double moved[7];
      pose_manifold.Plus(pose, delta.data(), moved);
      return evaluate(moved, point.data(), line_params);
    });
    const auto J_line_numeric = NumericJacobian<5, 4>([&](const Eigen::Vector4d& delta) {
      double moved[6];
      line_manifold.Plus(line_params, delta.data(), moved);
      return evaluate(pose, point.data(), moved);
    });
    const auto J_point_numeric = NumericJacobian<5, 3>([&](const Eigen::Vector3d& delta) {
      const Eigen::Vector3d moved = point + delta;
      return evaluate(pose, moved.data(), line_params);
    });
    EXPECT_LT(RelativeError(Eigen::Matrix<double, 5, 6>(J_pose * plus_pose), J_pose_numeric),
              kTolerance);
    EXPECT_LT(RelativeError(Eigen::Matrix<double, 5, 4>(J_line * plus_line), J_line_numeric),
              kTolerance);
    EXPECT_LT(RelativeError(Eigen::Matrix<double, 5, 3>(J_point), J_point_numeric), kTolerance);

    // Virtual observation cost through the same manifolds.
    const Eigen::Vector3d n_v = LinePlaneNormal(RandomPose(&rng, 0.01, 0.01) * cam_from_world,
                                                line);
    const internal::VirtualObservationCost virtual_cost(n_v, 2e-3);
    double* vparams[2] = {pose, line_params};
    Eigen::Vector2d vr;
    Eigen::Matrix<double, 2, 7, Eigen::RowMajor> Jv_pose;
    Eigen::Matrix<double, 2, 6, Eigen::RowMajor> Jv_line;
    double* vjac[2] = {Jv_pose.data(), Jv_line.data()};
    ASSERT_TRUE(virtual_cost.Evaluate(vparams, vr.data(), vjac));
    const auto Jv_pose_numeric = NumericJacobian<2, 6>([&](const Vector6d& delta) {
      double moved[7];
      pose_manifold.Plus(pose, delta.data(), moved);
      const double* ps[2] = {moved, line_params};
      Eigen::Vector2d out;
      EXPECT_TRUE(virtual_cost.Evaluate(ps, out.data(), nullptr));
      return out;
    });
    EXPECT_LT(RelativeError(Eigen::Matrix<double, 2, 6>(Jv_pose * plus_pose), Jv_pose_numeric),
              kTolerance);
    const auto Jv_line_numeric = NumericJacobian<2, 4>([&](const Eigen::Vector4d& delta) {
      double moved[6];
      line_manifold.Plus(line_params, delta.data(), moved);
      const double* ps[2] = {pose, moved};
      Eigen::Vector2d out;
      EXPECT_TRUE(virtual_cost.Evaluate(ps, out.data(), nullptr));
      return out;
    });
    EXPECT_LT(RelativeError(Eigen::Matrix<double, 2, 4>(Jv_line * plus_line), Jv_line_numeric),
              kTolerance);
  }
}

// A line and its X' as one block (bundle_adjustment.cc): SubBlockCost feeds the parts of
// [line (6), X' (3)] to the costs written for separate blocks, and the product of its Jacobian
// with LineWithPointManifold's PlusJacobian is the tangent Jacobian [line (4), X' (3)].
TEST(CeresCosts, LineWithItsPointAsOneBlockMatchesCentralDifferences) {
  std::mt19937 rng(23);
  const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(CameraModel::kPerspective));
  internal::PoseManifold pose_manifold;
  const internal::LineWithPointManifold joint_manifold;
  ASSERT_EQ(joint_manifold.AmbientSize(), internal::kLineWithPointSize);
  ASSERT_EQ(joint_manifold.TangentSize(), internal::kLineTangentSize + 3);
  using Part = internal::SubBlockCost::Part;
  for (int trial = 0; trial < 5; ++trial) {
    const Rigid3d cam_from_world = RandomPose(&rng, 0.5, 1.0);
    const Eigen::Vector3d x =
        cam_from_world.Inverse() * RandomVisiblePoint(CameraModel::kPerspective, &rng);
    const Line3d line(x + Eigen::Vector3d(0.04, 0.03, -0.02), Eigen::Vector3d(0.6, 0, 0.8));
    const Eigen::Matrix3d S =
        SqrtInformation(LineInformation(line.direction, 0.01 * Eigen::Matrix3d::Identity()));
    double pose[7], joint[internal::kLineWithPointSize];
    internal::PoseToParameters(cam_from_world, pose);
    internal::LineToParameters(line, joint);
    Eigen::Map<Eigen::Vector3d>(joint + internal::kLineSize) = x;

    const internal::SubBlockCost cost(
        std::make_unique<internal::FreeLineObservationCost>(camera.get(),
                                                            Eigen::Vector2d(300, 200), 0.8, S,
                                                            1.5),
        {internal::kPoseSize, internal::kLineWithPointSize},
        {Part{0, 0}, Part{1, internal::kLineSize}, Part{1, 0}});
    ASSERT_EQ(cost.num_residuals(), 5);
    auto evaluate = [&](const double* p, const double* j) {
      const double* ps[2] = {p, j};
      Eigen::Matrix<double, 5, 1> out;
      EXPECT_TRUE(cost.Evaluate(ps, out.data(), nullptr));
      return out;
    };
    // The same residual as the cost on separate blocks.
    {
      const internal::FreeLineObservationCost separate(camera.get(), Eigen::Vector2d(300, 200),
                                                       0.8, S, 1.5);
      const double* ps[3] = {pose, joint + internal::kLineSize, joint};
      Eigen::Matrix<double, 5, 1> expected;
      ASSERT_TRUE(separate.Evaluate(ps, expected.data(), nullptr));
      EXPECT_LT((evaluate(pose, joint) - expected).norm(), 1e-15);
    }
    Eigen::Matrix<double, 5, 1> r;
    Eigen::Matrix<double, 5, 7, Eigen::RowMajor> J_pose;
    Eigen::Matrix<double, 5, internal::kLineWithPointSize, Eigen::RowMajor> J_joint;
    J_joint.setConstant(123.0);  // every column is written, the uncovered ones with zeros
    double* jacobians[2] = {J_pose.data(), J_joint.data()};
    const double* params[2] = {pose, joint};
    ASSERT_TRUE(cost.Evaluate(params, r.data(), jacobians));
    Eigen::Matrix<double, 7, 6, Eigen::RowMajor> plus_pose;
    Eigen::Matrix<double, internal::kLineWithPointSize, 7, Eigen::RowMajor> plus_joint;
    pose_manifold.PlusJacobian(pose, plus_pose.data());
    joint_manifold.PlusJacobian(joint, plus_joint.data());
    const auto J_pose_numeric = NumericJacobian<5, 6>([&](const Vector6d& delta) {
      double moved[7];
      pose_manifold.Plus(pose, delta.data(), moved);
      return evaluate(moved, joint);
    });
    const auto J_joint_numeric =
        NumericJacobian<5, 7>([&](const Eigen::Matrix<double, 7, 1>& delta) {
          double moved[internal::kLineWithPointSize];
          joint_manifold.Plus(joint, delta.data(), moved);
          return evaluate(pose, moved);
        });
    EXPECT_LT(RelativeError(Eigen::Matrix<double, 5, 6>(J_pose * plus_pose), J_pose_numeric),
              kTolerance);
    EXPECT_LT(RelativeError(Eigen::Matrix<double, 5, 7>(J_joint * plus_joint), J_joint_numeric),
              kTolerance);
    // A constant pose block: no Jacobian asked for it, the joint block's is still written.
    double* joint_only[2] = {nullptr, J_joint.data()};
    ASSERT_TRUE(cost.Evaluate(params, r.data(), joint_only));
    EXPECT_LT(RelativeError(Eigen::Matrix<double, 5, 7>(J_joint * plus_joint), J_joint_numeric),
              kTolerance);

    // The virtual observation reads the line part only; the X' columns are zero.
    const Eigen::Vector3d n_v = LinePlaneNormal(RandomPose(&rng, 0.01, 0.01) * cam_from_world,
                                                line);
    const internal::SubBlockCost virtual_cost(
        std::make_unique<internal::VirtualObservationCost>(n_v, 2e-3),
        {internal::kPoseSize, internal::kLineWithPointSize}, {Part{0, 0}, Part{1, 0}});
    Eigen::Vector2d vr;
    Eigen::Matrix<double, 2, 7, Eigen::RowMajor> Jv_pose;
    Eigen::Matrix<double, 2, internal::kLineWithPointSize, Eigen::RowMajor> Jv_joint;
    Jv_joint.setConstant(123.0);
    double* vjac[2] = {Jv_pose.data(), Jv_joint.data()};
    ASSERT_TRUE(virtual_cost.Evaluate(params, vr.data(), vjac));
    EXPECT_TRUE(Jv_joint.rightCols<3>().isZero(0.0));
    const auto Jv_joint_numeric =
        NumericJacobian<2, 7>([&](const Eigen::Matrix<double, 7, 1>& delta) {
          double moved[internal::kLineWithPointSize];
          joint_manifold.Plus(joint, delta.data(), moved);
          const double* ps[2] = {pose, moved};
          Eigen::Vector2d out;
          EXPECT_TRUE(virtual_cost.Evaluate(ps, out.data(), nullptr));
          return out;
        });
    EXPECT_LT(RelativeError(Eigen::Matrix<double, 2, 7>(Jv_joint * plus_joint), Jv_joint_numeric),
              kTolerance);
  }
}

// The rigid-stereo form: the pose block is reference_from_world, the camera sits at a fixed
// offset cam_from_reference; the Jacobian goes through the SE(3) adjoint.
TEST(CeresCosts, LineObservationWithFixedOffsetMatchesCentralDifferences) {
  std::mt19937 rng(29);
  for (const CameraModel model : AllCameraModels()) {
    SCOPED_TRACE(CameraModelName(model));
    const std::unique_ptr<Camera> camera = MakeCamera(TestCameraParams(model));
    internal::PoseManifold pose_manifold;
    const Rigid3d reference_from_world = RandomPose(&rng, 0.5, 1.0);
    const Rigid3d cam_from_reference = RandomPose(&rng, 0.1, 0.5);
    const Rigid3d cam_from_world = cam_from_reference * reference_from_world;
    const Eigen::Vector3d x = cam_from_world.Inverse() * RandomVisiblePoint(model, &rng);
    const Line3d line(x + Eigen::Vector3d(0.05, -0.02, 0.03), Eigen::Vector3d(0.6, 0.0, 0.8));
    const Eigen::Matrix3d S =
        SqrtInformation(LineInformation(line.direction, 0.01 * Eigen::Matrix3d::Identity()));
    const internal::LineObservationCost cost(camera.get(), Eigen::Vector2d(300, 150), 0.8, line,
                                             S, 1.5, cam_from_reference);
    double pose[7];
    internal::PoseToParameters(reference_from_world, pose);
    Eigen::Vector3d point = x;
    double* params[2] = {pose, point.data()};
    Eigen::Matrix<double, 5, 1> r;
    Eigen::Matrix<double, 5, 7, Eigen::RowMajor> J_pose;
    Eigen::Matrix<double, 5, 3, Eigen::RowMajor> J_point;
    double* jacobians[2] = {J_pose.data(), J_point.data()};
    ASSERT_TRUE(cost.Evaluate(params, r.data(), jacobians));
    // Same residual as the direct form at the composed pose.
    Eigen::Vector2d r_px;
    ASSERT_TRUE(ReprojectionResidual(*camera, cam_from_world, x, Eigen::Vector2d(300, 150),
                                     &r_px));
    EXPECT_LT((r.head<2>() - std::sqrt(0.8) * r_px).norm(), 1e-9);
    Eigen::Matrix<double, 7, 6, Eigen::RowMajor> plus_pose;
    pose_manifold.PlusJacobian(pose, plus_pose.data());
    const auto J_pose_numeric = NumericJacobian<5, 6>([&](const Vector6d& delta) {
      double moved[7];
      pose_manifold.Plus(pose, delta.data(), moved);
      const double* ps[2] = {moved, point.data()};
      Eigen::Matrix<double, 5, 1> out;
      EXPECT_TRUE(cost.Evaluate(ps, out.data(), nullptr));
      return out;
    });
    EXPECT_LT(RelativeError(Eigen::Matrix<double, 5, 6>(J_pose * plus_pose), J_pose_numeric),
              kTolerance);
  }
}

TEST(CeresCosts, CentreDistanceJacobianMatchesCentralDifferences) {
  std::mt19937 rng(31);
  internal::PoseManifold pose_manifold;
  for (int trial = 0; trial < 5; ++trial) {
    const Rigid3d cam_from_world = RandomPose(&rng, 1.0, 3.0);
    const Eigen::Vector3d fixed_centre = RandomPose(&rng, 0.1, 2.0).translation;
    const double distance = 0.5 + trial;
    const internal::CentreDistanceCost cost(fixed_centre, distance, 7.0);
    double pose[7];
    internal::PoseToParameters(cam_from_world, pose);
    const double* params[1] = {pose};
    double r = 0.0;
    Eigen::Matrix<double, 1, 7, Eigen::RowMajor> J_pose;
    double* jacobians[1] = {J_pose.data()};
    ASSERT_TRUE(cost.Evaluate(params, &r, jacobians));
    EXPECT_NEAR(r, 7.0 * ((cam_from_world.Center() - fixed_centre).norm() - distance), 1e-12);
    Eigen::Matrix<double, 7, 6, Eigen::RowMajor> plus_pose;
    pose_manifold.PlusJacobian(pose, plus_pose.data());
    const auto J_numeric = NumericJacobian<1, 6>([&](const Vector6d& delta) {
      double moved[7];
      pose_manifold.Plus(pose, delta.data(), moved);
      const double* ps[1] = {moved};
      Eigen::Matrix<double, 1, 1> out;
      EXPECT_TRUE(cost.Evaluate(ps, out.data(), nullptr));
      return out;
    });
    EXPECT_LT(RelativeError(Eigen::Matrix<double, 1, 6>(J_pose * plus_pose), J_numeric),
              kTolerance);
  }
  // Coincident centres: no direction, no residual.
  const Rigid3d at_origin;
  double pose[7];
  internal::PoseToParameters(at_origin, pose);
  const double* params[1] = {pose};
  double r = 0.0;
  EXPECT_FALSE(internal::CentreDistanceCost(Eigen::Vector3d::Zero(), 1.0, 1.0)
                   .Evaluate(params, &r, nullptr));
}

TEST(CeresCosts, ManifoldMinusInvertsPlus) {
  std::mt19937 rng(23);
  internal::PoseManifold pose_manifold;
  internal::LineManifold line_manifold;
  double pose[7], moved_pose[7], line[6], moved_line[6];
  internal::PoseToParameters(RandomPose(&rng, 1.0, 1.0), pose);
  internal::LineToParameters(RandomLine(&rng), line);
  Vector6d delta;
  delta << 0.1, -0.2, 0.05, 0.02, 0.03, -0.04;
  const Eigen::Vector4d line_delta(0.1, -0.05, 0.03, 0.02);
  pose_manifold.Plus(pose, delta.data(), moved_pose);
  line_manifold.Plus(line, line_delta.data(), moved_line);
  Vector6d back;
  Eigen::Vector4d line_back;
  pose_manifold.Minus(moved_pose, pose, back.data());
  line_manifold.Minus(moved_line, line, line_back.data());
  EXPECT_LT((back - delta).norm(), 1e-12);
  EXPECT_LT((line_back - line_delta).norm(), 1e-12);
}

}  // namespace
}  // namespace lcv::slam
