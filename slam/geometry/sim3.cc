#include "slam/geometry/sim3.h"

#include <cmath>

namespace lcv::slam {
namespace {

// The matrix W with translation = W * v in the Sim(3) exponential (Strasdat's thesis, and the
// closed form used by Sophus' sim_details.hpp).
Eigen::Matrix3d SimilarityW(const Eigen::Vector3d& omega, double sigma) {
  constexpr double kEps = 1e-8;
  const double theta = omega.norm();
  const Eigen::Matrix3d W1 = SkewSymmetric(omega);
  const Eigen::Matrix3d W2 = W1 * W1;
  const double scale = std::exp(sigma);
  double A, B, C;
  if (std::abs(sigma) < kEps) {
    C = 1.0;
    if (theta < kEps) {
      A = 0.5;
      B = 1.0 / 6.0;
    } else {
      const double t2 = theta * theta;
      A = (1.0 - std::cos(theta)) / t2;
      B = (theta - std::sin(theta)) / (t2 * theta);
    }
  } else {
    C = (scale - 1.0) / sigma;
    if (theta < kEps) {
      const double s2 = sigma * sigma;
      A = ((sigma - 1.0) * scale + 1.0) / s2;
      B = (scale * 0.5 * s2 + scale - 1.0 - sigma * scale) / (s2 * sigma);
    } else {
      const double t2 = theta * theta;
      const double a = scale * std::sin(theta);
      const double b = scale * std::cos(theta);
      const double c = t2 + sigma * sigma;
      A = (a * sigma + (1.0 - b) * theta) / (theta * c);
      B = (C - ((b - 1.0) * sigma + a * theta) / c) / t2;
    }
  }
  return A * W1 + B * W2 + C * Eigen::Matrix3d::Identity();
}

}  // namespace

Sim3d Sim3d::Exp(const Vector7d& delta) {
  const Eigen::Vector3d v = delta.head<3>();
  const Eigen::Vector3d omega = delta.segment<3>(3);
  const double sigma = delta(6);
  return Sim3d(std::exp(sigma), ExpSO3(omega), SimilarityW(omega, sigma) * v);
}

Vector7d Sim3d::Log() const {
  Vector7d out;
  const Eigen::Vector3d omega = LogSO3(rotation);
  const double sigma = std::log(scale);
  out.head<3>() = SimilarityW(omega, sigma).partialPivLu().solve(translation);
  out.segment<3>(3) = omega;
  out(6) = sigma;
  return out;
}

Rigid3d TransformPose(const Sim3d& world2_from_world1, const Rigid3d& cam_from_world1) {
  // x_cam (in world2 units) = s * (Rc * x1 + tc), x1 = R^T (x2 - t) / s.
  const Eigen::Quaterniond rotation = cam_from_world1.rotation * world2_from_world1.rotation.conjugate();
  const Eigen::Vector3d translation = world2_from_world1.scale * cam_from_world1.translation -
                                      rotation * world2_from_world1.translation;
  return Rigid3d(rotation.normalized(), translation);
}

}  // namespace lcv::slam
