#include "slam/camera/equirectangular.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "tests/slam/camera/camera_test_cameras.h"

namespace lcv::slam {
namespace {

TEST(EquirectangularCamera, KnownDirectionsLandOnKnownPixels) {
  const EquirectangularCamera camera(test::EquirectangularParams());
  const double cols = 1920, rows = 960;
  const auto expect_pixel = [&](const Eigen::Vector3d& p, double u, double v) {
    const auto px = camera.Project(p);
    ASSERT_TRUE(px.has_value()) << p.transpose();
    EXPECT_NEAR(px->x(), u, 1e-9) << p.transpose();
    EXPECT_NEAR(px->y(), v, 1e-9) << p.transpose();
  };
  expect_pixel(Eigen::Vector3d(0, 0, 5), cols / 2, rows / 2);       // ahead: centre
  expect_pixel(Eigen::Vector3d(3, 0, 0), 3 * cols / 4, rows / 2);   // right
  expect_pixel(Eigen::Vector3d(-3, 0, 0), cols / 4, rows / 2);      // left
  expect_pixel(Eigen::Vector3d(0, -1, 1), cols / 2, rows / 4);      // 45 degrees up (y down)
  expect_pixel(Eigen::Vector3d(0, 2, 2), cols / 2, 3 * rows / 4);   // 45 degrees down
  expect_pixel(Eigen::Vector3d(1e-12, 0, -1), cols, rows / 2);      // behind, right of the seam
  expect_pixel(Eigen::Vector3d(-1e-12, 0, -1), 0, rows / 2);        // behind, left of the seam
}

TEST(EquirectangularCamera, PolesAndOriginAreEmpty) {
  const EquirectangularCamera camera(test::EquirectangularParams());
  Eigen::Matrix<double, 2, 3> J;
  EXPECT_FALSE(camera.Project(Eigen::Vector3d(0, -1, 0), &J).has_value());
  EXPECT_FALSE(camera.Project(Eigen::Vector3d(0, 1, 0), &J).has_value());
  EXPECT_FALSE(camera.Project(Eigen::Vector3d::Zero(), &J).has_value());
  // Next to the pole: defined and finite.
  const auto px = camera.Project(Eigen::Vector3d(1e-9, -1, 0), &J);
  ASSERT_TRUE(px.has_value());
  EXPECT_TRUE(J.allFinite());
  EXPECT_NEAR(px->y(), 0.0, 1e-3);
  EXPECT_EQ(camera.MaxViewAngle(), M_PI);
}

TEST(EquirectangularCamera, UnprojectWrapsColumnsAndRefusesRowsOutside) {
  const EquirectangularCamera camera(test::EquirectangularParams());
  const auto a = camera.Unproject(Eigen::Vector2d(100.25, 300.5));
  const auto b = camera.Unproject(Eigen::Vector2d(100.25 + 1920, 300.5));
  ASSERT_TRUE(a.has_value());
  ASSERT_TRUE(b.has_value());
  EXPECT_LT((*a - *b).norm(), 1e-12);
  EXPECT_FALSE(camera.Unproject(Eigen::Vector2d(10, -0.5)).has_value());
  EXPECT_FALSE(camera.Unproject(Eigen::Vector2d(10, 960.5)).has_value());
  const auto top = camera.Unproject(Eigen::Vector2d(10, 0));
  ASSERT_TRUE(top.has_value());
  EXPECT_NEAR(top->y(), -1.0, 1e-12);  // the north pole is up, y down
}

TEST(EquirectangularCamera, ProjectApproxMatchesProjectAndItsJacobian) {
  const EquirectangularCamera camera(test::EquirectangularParams());
  std::mt19937 rng(3);
  std::normal_distribution<double> normal;
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Vector3d p(normal(rng), normal(rng), normal(rng));
    const Eigen::Vector3d tangent(normal(rng), normal(rng), normal(rng));
    Eigen::Matrix<double, 2, 3> J;
    const auto exact = camera.Project(p, &J);
    double speed = -1.0;
    const auto approx = camera.ProjectApprox(p, tangent, &speed);
    ASSERT_EQ(exact.has_value(), approx.has_value());
    if (!exact) continue;
    EXPECT_LT((*approx - *exact).norm(), 1e-7) << p.transpose();
    EXPECT_NEAR(speed, (J * tangent).norm(), 1e-9 * (1.0 + speed)) << p.transpose();
  }
  double speed = 0.0;
  EXPECT_FALSE(camera.ProjectApprox(Eigen::Vector3d(0, 1, 0), Eigen::Vector3d::UnitX(), &speed));
  EXPECT_FALSE(camera.ProjectApprox(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(), &speed));
}

}  // namespace
}  // namespace lcv::slam
