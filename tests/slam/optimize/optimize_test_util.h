#pragma once
// Shared helpers of the slam/optimize tests: the three camera models at 640x360, random poses,
// and central-difference Jacobians through a retraction.

#include <memory>
#include <random>
#include <vector>

#include <Eigen/Core>

#include "slam/camera/camera.h"
#include "slam/geometry/rigid3.h"
#include "slam/geometry/so3.h"

namespace lcv::slam::testing {

inline CameraParams TestCameraParams(CameraModel model) {
  CameraParams params;
  params.model = model;
  params.cols = 640;
  params.rows = 360;
  switch (model) {
    case CameraModel::kPerspective:
      params.fx = 450.0;
      params.fy = 455.0;
      params.cx = 319.5;
      params.cy = 179.5;
      params.distortion = {-0.08, 0.02, 0.0005, -0.0003, 0.0};
      break;
    case CameraModel::kFisheye:
      params.fx = 260.0;
      params.fy = 260.0;
      params.cx = 320.0;
      params.cy = 180.0;
      params.distortion = {0.02, -0.01, 0.003, -0.001, 0.0};
      break;
    case CameraModel::kEquirectangular:
      break;
  }
  return params;
}

inline std::vector<CameraModel> AllCameraModels() {
  return {CameraModel::kPerspective, CameraModel::kFisheye, CameraModel::kEquirectangular};
}

inline Rigid3d RandomPose(std::mt19937* rng, double rotation_rad, double translation) {
  std::normal_distribution<double> normal(0.0, 1.0);
  const Eigen::Vector3d omega(normal(*rng), normal(*rng), normal(*rng));
  const Eigen::Vector3d t(normal(*rng), normal(*rng), normal(*rng));
  return Rigid3d(ExpSO3(rotation_rad * omega.normalized()), translation * t);
}

// Central differences of f(Retract(x, h e_i)) for i < kTangent; f returns a fixed-size vector.
template <int kRows, int kTangent, typename F>
Eigen::Matrix<double, kRows, kTangent> NumericJacobian(F&& f, double step = 1e-6) {
  Eigen::Matrix<double, kRows, kTangent> J;
  for (int i = 0; i < kTangent; ++i) {
    Eigen::Matrix<double, kTangent, 1> delta = Eigen::Matrix<double, kTangent, 1>::Zero();
    delta(i) = step;
    const Eigen::Matrix<double, kRows, 1> plus = f(delta);
    delta(i) = -step;
    const Eigen::Matrix<double, kRows, 1> minus = f(delta);
    J.col(i) = (plus - minus) / (2.0 * step);
  }
  return J;
}

// max |a - b| / max(1, max |b|): the relative error used for Jacobian checks.
template <typename A, typename B>
double RelativeError(const A& a, const B& b) {
  return (a - b).cwiseAbs().maxCoeff() / std::max(1.0, b.cwiseAbs().maxCoeff());
}

}  // namespace lcv::slam::testing
