#pragma once
// Test cameras shared by the camera tests: one realistic set of intrinsics per model, and
// samplers for pixels and points inside each model's valid region.

#include <algorithm>
#include <cmath>
#include <random>

#include <Eigen/Core>

#include "slam/camera/camera.h"

namespace lcv::slam::test {

// EuRoC MAV cam0 (752x480), radial-tangential.
inline CameraParams EurocParams() {
  CameraParams p;
  p.name = "euroc_cam0";
  p.model = CameraModel::kPerspective;
  p.cols = 752;
  p.rows = 480;
  p.fx = 458.654;
  p.fy = 457.296;
  p.cx = 367.215;
  p.cy = 248.375;
  p.distortion = {-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05, 0.0};
  return p;
}

// A strongly distorted wide perspective lens with all five coefficients.
inline CameraParams WidePerspectiveParams() {
  CameraParams p;
  p.name = "wide";
  p.model = CameraModel::kPerspective;
  p.cols = 1280;
  p.rows = 720;
  p.fx = 520.0;
  p.fy = 515.0;
  p.cx = 641.5;
  p.cy = 357.25;
  p.distortion = {-0.21, 0.031, -0.0012, 0.0007, 0.0011};
  return p;
}

// TUM-VI (512x512) Kannala-Brandt lens, about 195 degrees across the image diagonal.
inline CameraParams TumViFisheyeParams() {
  CameraParams p;
  p.name = "tumvi_cam0";
  p.model = CameraModel::kFisheye;
  p.cols = 512;
  p.rows = 512;
  p.fx = 190.97847715128717;
  p.fy = 190.9733070521226;
  p.cx = 254.93170605935475;
  p.cy = 256.8974428996504;
  p.distortion = {0.0034823894022493434, 0.0007150348452162257, -0.0020532361418706202,
                  0.00020293673591811182, 0.0};
  return p;
}

// An equidistant 200-degree lens: zero k's, f chosen so that the image circle (radius 500 px)
// reaches 100 degrees from the axis.
inline CameraParams Fisheye200Params() {
  CameraParams p;
  p.name = "fisheye200";
  p.model = CameraModel::kFisheye;
  p.cols = 1000;
  p.rows = 1000;
  p.fx = p.fy = 500.0 / (100.0 * M_PI / 180.0);
  p.cx = 499.5;
  p.cy = 499.5;
  p.distortion = {0.0, 0.0, 0.0, 0.0, 0.0};
  return p;
}

inline CameraParams EquirectangularParams() {
  CameraParams p;
  p.name = "theta_s";
  p.model = CameraModel::kEquirectangular;
  p.cols = 1920;
  p.rows = 960;
  return p;
}

// Largest angle from the axis that a test samples: inside the model's valid angle, and (for the
// pinhole models) inside the image-forming disc where Unproject is accurate.
inline double SampleAngleLimit(const Camera& camera) {
  return std::min(camera.MaxViewAngle() * 0.98, camera.model() == CameraModel::kEquirectangular
                                                    ? M_PI
                                                    : 175.0 * M_PI / 180.0);
}

// A uniformly random unit vector at most max_angle from +z.
inline Eigen::Vector3d RandomBearing(std::mt19937_64& rng, double max_angle) {
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const double cos_min = std::cos(max_angle);
  const double z = 1.0 - uniform(rng) * (1.0 - cos_min);
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  const double phi = 2.0 * M_PI * uniform(rng);
  return Eigen::Vector3d(r * std::cos(phi), r * std::sin(phi), z);
}

// A pixel uniformly inside the image where the camera's model is defined (drawn by rejection).
inline Eigen::Vector2d RandomValidPixel(const Camera& camera, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, camera.cols() - 1.0);
  std::uniform_real_distribution<double> v(0.0, camera.rows() - 1.0);
  const double limit = SampleAngleLimit(camera);
  for (;;) {
    const Eigen::Vector2d px(u(rng), v(rng));
    if (camera.model() == CameraModel::kPerspective) return px;  // whole image is valid
    if (camera.model() == CameraModel::kEquirectangular) return px;
    // Fisheye: keep pixels whose normalized radius is below theta_d(limit), computed here from
    // the Kannala-Brandt polynomial so that the filter does not depend on the code under test.
    const CameraParams& p = camera.params();
    const double radius = std::hypot((px.x() - p.cx) / p.fx, (px.y() - p.cy) / p.fy);
    const double t2 = limit * limit;
    const auto& k = p.distortion;
    const double theta_d_limit =
        limit * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))));
    if (radius < theta_d_limit) return px;
  }
}

}  // namespace lcv::slam::test
