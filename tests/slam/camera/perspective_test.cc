#include "slam/camera/perspective.h"

#include <cmath>

#include <gtest/gtest.h>

#include "tests/slam/camera/camera_test_cameras.h"

namespace lcv::slam {
namespace {

CameraParams PinholeParams() {
  CameraParams p = test::EurocParams();
  p.distortion = {0, 0, 0, 0, 0};
  return p;
}

TEST(PerspectiveCamera, PinholeProjectsByDivision) {
  const PerspectiveCamera camera(PinholeParams());
  const auto px = camera.Project(Eigen::Vector3d(1.0, 2.0, 4.0));
  ASSERT_TRUE(px.has_value());
  EXPECT_NEAR(px->x(), 458.654 * 0.25 + 367.215, 1e-12);
  EXPECT_NEAR(px->y(), 457.296 * 0.5 + 248.375, 1e-12);
  const auto bearing = camera.Unproject(*px);
  ASSERT_TRUE(bearing.has_value());
  EXPECT_LT((*bearing - Eigen::Vector3d(1, 2, 4).normalized()).norm(), 1e-15);
}

TEST(PerspectiveCamera, DistortionMatchesOpenCvFormula) {
  const CameraParams params = test::WidePerspectiveParams();
  const PerspectiveCamera camera(params);
  const double k1 = params.distortion[0], k2 = params.distortion[1], p1 = params.distortion[2],
               p2 = params.distortion[3], k3 = params.distortion[4];
  // cv::projectPoints, written out term by term.
  const double x = -0.3 / 1.5, y = 0.45 / 1.5;
  const double r2 = x * x + y * y;
  const double radial = 1 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
  const double xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
  const double yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
  const auto px = camera.Project(Eigen::Vector3d(-0.3, 0.45, 1.5));
  ASSERT_TRUE(px.has_value());
  EXPECT_NEAR(px->x(), params.fx * xd + params.cx, 1e-10);
  EXPECT_NEAR(px->y(), params.fy * yd + params.cy, 1e-10);
}

TEST(PerspectiveCamera, BehindAndOnThePlaneAreEmpty) {
  const PerspectiveCamera camera(test::EurocParams());
  Eigen::Matrix<double, 2, 3> J;
  EXPECT_FALSE(camera.Project(Eigen::Vector3d(0.1, 0.1, -1.0), &J).has_value());
  EXPECT_FALSE(camera.Project(Eigen::Vector3d(0.1, 0.1, 0.0), &J).has_value());
  EXPECT_FALSE(camera.Project(Eigen::Vector3d(0.0, 0.0, -1e-300), &J).has_value());
  EXPECT_TRUE(camera.Project(Eigen::Vector3d(0.0, 0.0, 1e-3), &J).has_value());
}

// k1 = -0.4 alone: r (1 - 0.4 r^2) peaks at r = sqrt(1 / 1.2), where the image folds back.
TEST(PerspectiveCamera, FoldingDistortionLimitsTheValidRadius) {
  CameraParams params = PinholeParams();
  params.distortion = {-0.4, 0, 0, 0, 0};
  const PerspectiveCamera camera(params);
  const double r_fold = std::sqrt(1.0 / 1.2);
  EXPECT_NEAR(camera.max_undistorted_radius(), r_fold, 1e-9);
  EXPECT_NEAR(camera.MaxViewAngle(), std::atan(r_fold), 1e-9);
  EXPECT_TRUE(camera.Project(Eigen::Vector3d(0.9 * r_fold, 0, 1)).has_value());
  // Beyond the fold the point would land back inside the image at a wrong place: refused.
  EXPECT_FALSE(camera.Project(Eigen::Vector3d(1.05 * r_fold, 0, 1)).has_value());
  EXPECT_FALSE(camera.Project(Eigen::Vector3d(0, 2.0, 1)).has_value());

  // Distorted radius at the fold: the largest radius any valid point reaches.
  const double rd_fold = r_fold * (1.0 - 0.4 * r_fold * r_fold);
  const Eigen::Vector2d inside(params.cx + params.fx * 0.98 * rd_fold, params.cy);
  const auto bearing = camera.Unproject(inside);
  ASSERT_TRUE(bearing.has_value());
  EXPECT_LT(bearing->x() / bearing->z(), r_fold);  // the preimage inside the fold
  const auto reprojected = camera.Project(*bearing);
  ASSERT_TRUE(reprojected.has_value());
  EXPECT_LT((*reprojected - inside).norm(), 1e-6);
  const Eigen::Vector2d beyond(params.cx, params.cy + params.fy * 1.02 * rd_fold);
  EXPECT_FALSE(camera.Unproject(beyond).has_value());
}

TEST(PerspectiveCamera, UndistortionReachesTheImageCorners) {
  const CameraParams params = test::WidePerspectiveParams();
  const PerspectiveCamera camera(params);
  for (const Eigen::Vector2d& corner :
       {Eigen::Vector2d(0, 0), Eigen::Vector2d(params.cols - 1, 0),
        Eigen::Vector2d(0, params.rows - 1), Eigen::Vector2d(params.cols - 1, params.rows - 1)}) {
    const auto bearing = camera.Unproject(corner);
    ASSERT_TRUE(bearing.has_value()) << corner.transpose();
    const auto px = camera.Project(*bearing);
    ASSERT_TRUE(px.has_value());
    EXPECT_LT((*px - corner).norm(), 1e-8) << corner.transpose();
  }
}

TEST(PerspectiveCamera, MaxUndistortedRadiusWithoutFoldIsTheCap) {
  EXPECT_NEAR(PerspectiveCamera::MaxUndistortedRadius({0, 0, 0, 0, 0}),
              std::tan(89.9 * M_PI / 180.0), 1e-9);
  // EuRoC's polynomial slope 1 - 0.85 r^2 + 0.37 r^4 never reaches zero.
  EXPECT_NEAR(PerspectiveCamera::MaxUndistortedRadius(test::EurocParams().distortion),
              std::tan(89.9 * M_PI / 180.0), 1e-9);
  // k3 < 0 alone: slope 1 + 7 k3 r^6 = 0.
  EXPECT_NEAR(PerspectiveCamera::MaxUndistortedRadius({0, 0, 0, 0, -0.01}),
              std::pow(1.0 / 0.07, 1.0 / 6.0), 1e-9);
}

}  // namespace
}  // namespace lcv::slam
