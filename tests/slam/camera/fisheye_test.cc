#include "slam/camera/fisheye.h"

#include <cmath>

#include <gtest/gtest.h>

#include "tests/slam/camera/camera_test_cameras.h"

namespace lcv::slam {
namespace {

TEST(FisheyeCamera, EquidistantLensMapsAngleToRadius) {
  const CameraParams params = test::Fisheye200Params();
  const FisheyeCamera camera(params);
  EXPECT_NEAR(camera.MaxViewAngle(), M_PI - 1e-6, 1e-12);
  // 90 degrees to the right: radius f * pi / 2.
  auto px = camera.Project(Eigen::Vector3d(2.0, 0.0, 0.0));
  ASSERT_TRUE(px.has_value());
  EXPECT_NEAR(px->x(), params.cx + params.fx * M_PI / 2, 1e-9);
  EXPECT_NEAR(px->y(), params.cy, 1e-9);
  // 135 degrees, upwards (y < 0) and behind the camera.
  px = camera.Project(Eigen::Vector3d(0.0, -1.0, -1.0));
  ASSERT_TRUE(px.has_value());
  EXPECT_NEAR(px->x(), params.cx, 1e-9);
  EXPECT_NEAR(px->y(), params.cy - params.fy * 3 * M_PI / 4, 1e-9);
  const auto bearing = camera.Unproject(*px);
  ASSERT_TRUE(bearing.has_value());
  EXPECT_LT((*bearing - Eigen::Vector3d(0, -1, -1).normalized()).norm(), 1e-12);
}

TEST(FisheyeCamera, TwoHundredDegreeLensImagesPointsBehindItsPlane) {
  const FisheyeCamera camera(test::Fisheye200Params());
  // 99 degrees from the axis: inside the 500 px image circle, and inside the image.
  const double theta = 99.0 * M_PI / 180.0;
  const Eigen::Vector3d p(std::sin(theta) * std::cos(0.3), std::sin(theta) * std::sin(0.3),
                          std::cos(theta));
  ASSERT_LT(p.z(), 0.0);
  const auto px = camera.Project(p);
  ASSERT_TRUE(px.has_value());
  EXPECT_TRUE(camera.InImage(*px));
  EXPECT_NEAR((*px - Eigen::Vector2d(499.5, 499.5)).norm(), 500.0 * 99.0 / 100.0, 1e-9);
  const auto bearing = camera.Unproject(*px);
  ASSERT_TRUE(bearing.has_value());
  EXPECT_LT(bearing->z(), 0.0);
  EXPECT_LT((*bearing - p).norm(), 1e-12);
}

TEST(FisheyeCamera, TumViLensSeesMoreThanAHemisphere) {
  const CameraParams params = test::TumViFisheyeParams();
  const FisheyeCamera camera(params);
  EXPECT_GT(camera.MaxViewAngle(), M_PI / 2);
  // The image corner looks behind the image plane.
  const auto bearing = camera.Unproject(Eigen::Vector2d(0, 0));
  ASSERT_TRUE(bearing.has_value());
  EXPECT_LT(bearing->z(), 0.0);
}

// k1 = -0.1 alone: d(theta_d)/d(theta) = 1 - 0.3 theta^2 vanishes at theta = sqrt(1 / 0.3).
TEST(FisheyeCamera, FoldingPolynomialLimitsTheViewAngle) {
  CameraParams params = test::Fisheye200Params();
  params.distortion = {-0.1, 0, 0, 0, 0};
  const FisheyeCamera camera(params);
  const double theta_fold = std::sqrt(1.0 / 0.3);
  EXPECT_NEAR(camera.MaxViewAngle(), theta_fold, 1e-9);
  EXPECT_NEAR(FisheyeCamera::MaxValidAngle(params.distortion), theta_fold, 1e-9);
  const auto at = [](double theta) {
    return Eigen::Vector3d(std::sin(theta), 0.0, std::cos(theta));
  };
  EXPECT_TRUE(camera.Project(at(0.99 * theta_fold)).has_value());
  EXPECT_FALSE(camera.Project(at(1.01 * theta_fold)).has_value());
  EXPECT_FALSE(camera.Project(at(3.0)).has_value());
  const double theta_d_fold = theta_fold * (1 - 0.1 * theta_fold * theta_fold);
  EXPECT_FALSE(
      camera.Unproject(Eigen::Vector2d(params.cx + params.fx * theta_d_fold * 1.001, params.cy))
          .has_value());
  const auto bearing =
      camera.Unproject(Eigen::Vector2d(params.cx, params.cy + params.fy * theta_d_fold * 0.999));
  ASSERT_TRUE(bearing.has_value());
  EXPECT_LT(std::acos(bearing->z()), theta_fold);
}

TEST(FisheyeCamera, OpticalAxisHasThePinholeLimit) {
  const CameraParams params = test::TumViFisheyeParams();
  const FisheyeCamera camera(params);
  Eigen::Matrix<double, 2, 3> J;
  const auto px = camera.Project(Eigen::Vector3d(0, 0, 2.0), &J);
  ASSERT_TRUE(px.has_value());
  EXPECT_NEAR(px->x(), params.cx, 1e-12);
  EXPECT_NEAR(px->y(), params.cy, 1e-12);
  Eigen::Matrix<double, 2, 3> expected;
  expected << params.fx / 2, 0, 0, 0, params.fy / 2, 0;
  EXPECT_LT((J - expected).norm(), 1e-12) << J;
  const auto bearing = camera.Unproject(Eigen::Vector2d(params.cx, params.cy));
  ASSERT_TRUE(bearing.has_value());
  EXPECT_EQ(*bearing, Eigen::Vector3d::UnitZ());

  // Across the switch to the Taylor limit (1e-6 rad) the projection and its Jacobian stay
  // continuous and agree with central differences.
  for (double theta : {1e-9, 3e-7, 9.99e-7, 1.001e-6, 1e-5, 1e-3}) {
    const Eigen::Vector3d p(2.0 * std::sin(theta) * 0.6, 2.0 * std::sin(theta) * 0.8,
                            2.0 * std::cos(theta));
    Eigen::Matrix<double, 2, 3> J_p;
    const auto px_p = camera.Project(p, &J_p);
    ASSERT_TRUE(px_p.has_value());
    // Exact formula, far from any cancellation at these angles.
    const double t = std::atan2(std::hypot(p.x(), p.y()), p.z());
    const double scale = t / std::hypot(p.x(), p.y());
    EXPECT_NEAR(px_p->x(), params.fx * scale * p.x() + params.cx, 1e-9) << theta;
    EXPECT_NEAR(px_p->y(), params.fy * scale * p.y() + params.cy, 1e-9) << theta;
    Eigen::Matrix<double, 2, 3> J_numeric;
    const double h = 1e-6;
    for (int i = 0; i < 3; ++i) {
      Eigen::Vector3d plus = p, minus = p;
      plus(i) += h;
      minus(i) -= h;
      J_numeric.col(i) = (*camera.Project(plus) - *camera.Project(minus)) / (2 * h);
    }
    EXPECT_LT((J_p - J_numeric).norm(), 1e-6 * J_p.norm()) << theta << "\n" << J_p;
  }
}

}  // namespace
}  // namespace lcv::slam
