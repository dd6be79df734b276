// One typed battery over every camera model (STYLE.md 6): pixel round trips, point round trips,
// unit bearings, Jacobians against central differences, invalid inputs, batch forms. Plus the
// model-independent parts of camera.h (names, CameraParams::Problem, MakeCamera).
#include "slam/camera/camera.h"

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "tests/slam/camera/camera_test_cameras.h"

namespace lcv::slam {
namespace {

constexpr std::uint64_t kSeed = 20201123;

struct EurocCase {
  static CameraParams Params() { return test::EurocParams(); }
};
struct WidePerspectiveCase {
  static CameraParams Params() { return test::WidePerspectiveParams(); }
};
struct TumViFisheyeCase {
  static CameraParams Params() { return test::TumViFisheyeParams(); }
};
struct Fisheye200Case {
  static CameraParams Params() { return test::Fisheye200Params(); }
};
struct EquirectangularCase {
  static CameraParams Params() { return test::EquirectangularParams(); }
};

template <typename Case>
class CameraBattery : public ::testing::Test {
 protected:
  CameraBattery() : camera_(MakeCamera(Case::Params())), rng_(kSeed) {}
  std::unique_ptr<Camera> camera_;
  std::mt19937_64 rng_;
};

using CameraCases = ::testing::Types<EurocCase, WidePerspectiveCase, TumViFisheyeCase,
                                     Fisheye200Case, EquirectangularCase>;
TYPED_TEST_SUITE(CameraBattery, CameraCases);

// d(px)/d(p) by central differences.
Eigen::Matrix<double, 2, 3> NumericJacobian(const Camera& camera, const Eigen::Vector3d& p) {
  Eigen::Matrix<double, 2, 3> J;
  const double h = 1e-6 * p.norm();
  for (int i = 0; i < 3; ++i) {
    Eigen::Vector3d plus = p, minus = p;
    plus(i) += h;
    minus(i) -= h;
    const auto px_plus = camera.Project(plus);
    const auto px_minus = camera.Project(minus);
    if (!px_plus || !px_minus) return Eigen::Matrix<double, 2, 3>::Constant(NAN);
    J.col(i) = (*px_plus - *px_minus) / (2.0 * h);
  }
  return J;
}

TYPED_TEST(CameraBattery, PixelRoundTripBelowMicroPixel) {
  SCOPED_TRACE(::testing::Message() << "seed " << kSeed << ", camera " << this->camera_->params().name);
  const Camera& camera = *this->camera_;
  double worst_px = 0.0;
  for (int i = 0; i < 10000; ++i) {
    const Eigen::Vector2d px = test::RandomValidPixel(camera, this->rng_);
    const auto bearing = camera.Unproject(px);
    ASSERT_TRUE(bearing.has_value()) << "pixel " << px.transpose();
    ASSERT_NEAR(bearing->norm(), 1.0, 1e-12);
    // Any depth: the model only sees the ray.
    const auto reprojected = camera.Project(3.7 * *bearing);
    ASSERT_TRUE(reprojected.has_value()) << "pixel " << px.transpose();
    worst_px = std::max(worst_px, (*reprojected - px).norm());
  }
  EXPECT_LT(worst_px, 1e-6);
}

TYPED_TEST(CameraBattery, PointRoundTripGivesTheNormalizedPoint) {
  SCOPED_TRACE(::testing::Message() << "seed " << kSeed << ", camera " << this->camera_->params().name);
  const Camera& camera = *this->camera_;
  std::uniform_real_distribution<double> depth(0.1, 50.0);
  const double limit = test::SampleAngleLimit(camera);
  double worst = 0.0;
  for (int i = 0; i < 10000; ++i) {
    const Eigen::Vector3d direction = test::RandomBearing(this->rng_, limit);
    const Eigen::Vector3d p = depth(this->rng_) * direction;
    const auto px = camera.Project(p);
    ASSERT_TRUE(px.has_value()) << "point " << p.transpose();
    ASSERT_TRUE(px->allFinite());
    const auto bearing = camera.Unproject(*px);
    ASSERT_TRUE(bearing.has_value()) << "point " << p.transpose() << " px " << px->transpose();
    worst = std::max(worst, (*bearing - direction).norm());
  }
  EXPECT_LT(worst, 1e-9);
}

TYPED_TEST(CameraBattery, JacobianMatchesCentralDifferences) {
  SCOPED_TRACE(::testing::Message() << "seed " << kSeed << ", camera " << this->camera_->params().name);
  const Camera& camera = *this->camera_;
  std::uniform_real_distribution<double> depth(0.2, 20.0);
  const double limit = test::SampleAngleLimit(camera);
  int checked = 0;
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d p = depth(this->rng_) * test::RandomBearing(this->rng_, limit);
    // The equirectangular image wraps straight behind the camera: differences across the seam
    // are meaningless.
    if (camera.model() == CameraModel::kEquirectangular && p.z() < 0 &&
        std::abs(p.x()) < 1e-3 * p.norm()) {
      continue;
    }
    Eigen::Matrix<double, 2, 3> J;
    const auto px = camera.Project(p, &J);
    ASSERT_TRUE(px.has_value());
    const auto px_without = camera.Project(p);
    ASSERT_TRUE(px_without.has_value());
    EXPECT_EQ(*px, *px_without);
    const Eigen::Matrix<double, 2, 3> J_numeric = NumericJacobian(camera, p);
    ASSERT_TRUE(J_numeric.allFinite()) << "point " << p.transpose();
    ASSERT_LT((J - J_numeric).norm(), 1e-6 * J.norm())
        << "point " << p.transpose() << "\nanalytic\n" << J << "\nnumeric\n" << J_numeric;
    ++checked;
  }
  EXPECT_GT(checked, 1900);
}

TYPED_TEST(CameraBattery, DegenerateInputsGiveEmptyNeverNaN) {
  const Camera& camera = *this->camera_;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  Eigen::Matrix<double, 2, 3> J;
  EXPECT_FALSE(camera.Project(Eigen::Vector3d::Zero(), &J).has_value());
  EXPECT_FALSE(camera.Project(Eigen::Vector3d(nan, 0, 1), &J).has_value());
  EXPECT_FALSE(camera.Project(Eigen::Vector3d(0, 0, nan), &J).has_value());
  EXPECT_FALSE(camera.Project(Eigen::Vector3d(inf, 1, 1), &J).has_value());
  EXPECT_FALSE(camera.Unproject(Eigen::Vector2d(nan, 10)).has_value());
  EXPECT_FALSE(camera.Unproject(Eigen::Vector2d(10, nan)).has_value());
  EXPECT_FALSE(camera.Unproject(Eigen::Vector2d(inf, 10)).has_value());
  // Whatever any point of the sphere or any pixel gives, it is finite.
  for (int i = 0; i < 5000; ++i) {
    const Eigen::Vector3d p = test::RandomBearing(this->rng_, M_PI) * 2.0;
    const auto px = camera.Project(p, &J);
    if (px) {
      EXPECT_TRUE(px->allFinite());
      EXPECT_TRUE(J.allFinite());
      EXPECT_LT(std::acos(std::clamp(p.normalized().z(), -1.0, 1.0)), camera.MaxViewAngle());
    } else {
      EXPECT_GE(std::acos(std::clamp(p.normalized().z(), -1.0, 1.0)),
                camera.MaxViewAngle() - 1e-12)
          << "a point inside the valid angle failed to project: " << p.transpose();
    }
    std::uniform_real_distribution<double> far(-3.0 * camera.cols(), 4.0 * camera.cols());
    const auto bearing = camera.Unproject(Eigen::Vector2d(far(this->rng_), far(this->rng_)));
    if (bearing) {
      EXPECT_TRUE(bearing->allFinite());
      EXPECT_NEAR(bearing->norm(), 1.0, 1e-12);
    }
  }
}

TYPED_TEST(CameraBattery, BatchFormsEqualSingleCalls) {
  const Camera& camera = *this->camera_;
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> pixels;
  for (int i = 0; i < 500; ++i) {
    points.push_back(test::RandomBearing(this->rng_, M_PI) * 3.0);
    pixels.push_back(test::RandomValidPixel(camera, this->rng_));
  }
  points.push_back(Eigen::Vector3d::Zero());
  pixels.push_back(Eigen::Vector2d(NAN, 1.0));
  const int n = static_cast<int>(points.size());
  std::vector<Eigen::Vector2d> projected(n);
  std::vector<Eigen::Vector3d> bearings(n);
  std::vector<unsigned char> valid_projected(n), valid_bearings(n);
  camera.ProjectBatch(points.data(), n, projected.data(), valid_projected.data());
  camera.UnprojectBatch(pixels.data(), n, bearings.data(), valid_bearings.data());
  int num_projected = 0;
  for (int i = 0; i < n; ++i) {
    const auto px = camera.Project(points[i]);
    ASSERT_EQ(valid_projected[i] != 0, px.has_value());
    if (px) {
      EXPECT_EQ(projected[i], *px);
      ++num_projected;
    }
    const auto bearing = camera.Unproject(pixels[i]);
    ASSERT_EQ(valid_bearings[i] != 0, bearing.has_value());
    if (bearing) {
      EXPECT_EQ(bearings[i], *bearing);
    }
  }
  EXPECT_GT(num_projected, 0);
  EXPECT_EQ(valid_projected[n - 1], 0);
  EXPECT_EQ(valid_bearings[n - 1], 0);
}

TYPED_TEST(CameraBattery, InImageUsesPixelCentres) {
  const Camera& camera = *this->camera_;
  EXPECT_TRUE(camera.InImage(Eigen::Vector2d(0, 0)));
  EXPECT_TRUE(camera.InImage(Eigen::Vector2d(camera.cols() - 1, camera.rows() - 1)));
  EXPECT_FALSE(camera.InImage(Eigen::Vector2d(-0.01, 5)));
  EXPECT_FALSE(camera.InImage(Eigen::Vector2d(5, camera.rows() - 0.99)));
  EXPECT_FALSE(camera.InImage(Eigen::Vector2d(3, 3), 4.0));
  EXPECT_TRUE(camera.InImage(Eigen::Vector2d(4, 4), 4.0));
}

TEST(CameraModel, NamesRoundTrip) {
  for (CameraModel model :
       {CameraModel::kPerspective, CameraModel::kFisheye, CameraModel::kEquirectangular}) {
    const auto parsed = ParseCameraModel(CameraModelName(model));
    ASSERT_TRUE(parsed.has_value());
    EXPECT_EQ(*parsed, model);
  }
  EXPECT_EQ(ParseCameraModel("Perspective"), CameraModel::kPerspective);
  EXPECT_EQ(ParseCameraModel("Fisheye"), CameraModel::kFisheye);
  EXPECT_EQ(ParseCameraModel("Equirectangular"), CameraModel::kEquirectangular);
  EXPECT_FALSE(ParseCameraModel("pinhole").has_value());
  EXPECT_FALSE(ParseCameraModel("").has_value());
}

TEST(CameraParams, ProblemNamesTheBadField) {
  EXPECT_FALSE(test::EurocParams().Problem().has_value());
  EXPECT_FALSE(test::TumViFisheyeParams().Problem().has_value());
  EXPECT_FALSE(test::EquirectangularParams().Problem().has_value());

  const auto problem_of = [](CameraParams p) { return p.Problem().value_or("<none>"); };
  CameraParams p = test::EurocParams();
  p.fx = 0;
  EXPECT_NE(problem_of(p).find("fx"), std::string::npos) << problem_of(p);
  p = test::EurocParams();
  p.fy = -3;
  EXPECT_NE(problem_of(p).find("fy"), std::string::npos) << problem_of(p);
  p = test::EurocParams();
  p.cols = 0;
  EXPECT_NE(problem_of(p).find("cols"), std::string::npos) << problem_of(p);
  p = test::EquirectangularParams();
  p.rows = -1;
  EXPECT_NE(problem_of(p).find("rows"), std::string::npos) << problem_of(p);
  p = test::EurocParams();
  p.cx = NAN;
  EXPECT_NE(problem_of(p).find("cx"), std::string::npos) << problem_of(p);
  p = test::EurocParams();
  p.distortion[2] = INFINITY;
  EXPECT_NE(problem_of(p).find("p1"), std::string::npos) << problem_of(p);
  p = test::EurocParams();
  p.fps = 0;
  EXPECT_NE(problem_of(p).find("fps"), std::string::npos) << problem_of(p);
  p = test::TumViFisheyeParams();
  p.distortion[4] = 0.1;
  EXPECT_NE(problem_of(p).find("distortion[4]"), std::string::npos) << problem_of(p);
  p = test::TumViFisheyeParams();
  p.distortion[0] = -5000.0;  // folds at 0.47 degrees
  EXPECT_NE(problem_of(p).find("field of view"), std::string::npos) << problem_of(p);
  p = test::EurocParams();
  p.distortion[0] = -5000.0;
  EXPECT_NE(problem_of(p).find("field of view"), std::string::npos) << problem_of(p);
  // The pinhole fields do not matter for a panorama.
  p = test::EquirectangularParams();
  p.fx = 0;
  EXPECT_FALSE(p.Problem().has_value());
}

// Issue 16 item 4: finite but absurd values are refused by name (they overflowed later, in
// rendering and in map export).
TEST(CameraParams, ProblemRefusesImplausibleValues) {
  const auto problem_of = [](CameraParams p) { return p.Problem().value_or("<none>"); };
  const auto expect_problem = [&](const CameraParams& p, const std::string& field) {
    EXPECT_NE(problem_of(p).find(field), std::string::npos) << field << ": " << problem_of(p);
  };
  CameraParams p = test::EurocParams();
  p.fx = 1e300;
  expect_problem(p, "fx");
  p = test::EurocParams();
  p.fy = 5e-324;
  expect_problem(p, "fy");
  p = test::EurocParams();
  p.cx = 6e21;
  expect_problem(p, "cx");
  p = test::EurocParams();
  p.cy = -1e6;
  expect_problem(p, "cy");
  p = test::EurocParams();
  p.distortion[1] = 1.7e308;
  expect_problem(p, "k2");
  p = test::EquirectangularParams();
  p.cols = 100000;
  p.rows = 1;
  expect_problem(p, "cols");
  p = test::EurocParams();
  p.cols = 8000;
  p.rows = 100;
  expect_problem(p, "cols / rows");
  p = test::EurocParams();
  p.fy = p.fx * 20;
  expect_problem(p, "fx / fy");
  // Real cameras at the edges stay valid: a 32x24 test image, a 190-degree fisheye, a 16K pano.
  p = test::EurocParams();
  p.cols = 32;
  p.rows = 24;
  p.fx = p.fy = 30;
  p.cx = 15.5;
  p.cy = 11.5;
  EXPECT_FALSE(p.Problem().has_value()) << problem_of(p);
  p = test::EquirectangularParams();
  p.cols = 15360;
  p.rows = 7680;
  EXPECT_FALSE(p.Problem().has_value()) << problem_of(p);
}

TEST(MakeCamera, BuildsTheNamedModelAndRejectsBadParams) {
  EXPECT_EQ(MakeCamera(test::EurocParams())->model(), CameraModel::kPerspective);
  EXPECT_EQ(MakeCamera(test::TumViFisheyeParams())->model(), CameraModel::kFisheye);
  EXPECT_EQ(MakeCamera(test::EquirectangularParams())->model(), CameraModel::kEquirectangular);
  CameraParams bad = test::EurocParams();
  bad.fx = -1;
  EXPECT_THROW(MakeCamera(bad), std::logic_error);
}

}  // namespace
}  // namespace lcv::slam
