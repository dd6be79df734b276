#include "slam/geometry/so3.h"

#include <cmath>

namespace lcv::slam {

Eigen::Quaterniond ExpSO3(const Eigen::Vector3d& omega) {
  const double theta = omega.norm();
  const double half = 0.5 * theta;
  double real;
  double imag_factor;
  if (theta < 1e-8) {
    // sin(x/2)/x ~ 1/2 - x^2/48.
    real = 1.0 - theta * theta / 8.0;
    imag_factor = 0.5 - theta * theta / 48.0;
  } else {
    real = std::cos(half);
    imag_factor = std::sin(half) / theta;
  }
  Eigen::Quaterniond q(real, imag_factor * omega.x(), imag_factor * omega.y(),
                       imag_factor * omega.z());
  q.normalize();
  return q;
}

Eigen::Vector3d LogSO3(const Eigen::Quaterniond& q_in) {
  Eigen::Quaterniond q = q_in.normalized();
  if (q.w() < 0) q.coeffs() = -q.coeffs();  // shortest rotation, angle in [0, pi]
  const Eigen::Vector3d imag = q.vec();
  const double sin_half = imag.norm();
  if (sin_half < 1e-10) {
    // angle ~ 2*sin_half, axis*angle ~ 2*imag/w.
    return 2.0 * imag / q.w();
  }
  const double theta = 2.0 * std::atan2(sin_half, q.w());
  return theta / sin_half * imag;
}

Eigen::Matrix3d LeftJacobianSO3(const Eigen::Vector3d& omega) {
  // J = I + a W + b W^2 with a = (1 - cos t) / t^2 and b = (t - sin t) / t^3. Both textbook forms
  // cancel catastrophically for small t (1 - cos t loses all digits near 1e-8, and cost 1e-10
  // absolute error in J at t = 1e-6), so a is taken as 2 sin^2(t/2) / t^2 and b from its series.
  const double theta = omega.norm();
  const Eigen::Matrix3d W = SkewSymmetric(omega);
  const double t2 = theta * theta;
  double a, b;
  if (theta < 1e-2) {
    a = 0.5 - t2 / 24.0 * (1.0 - t2 / 30.0 * (1.0 - t2 / 56.0));
    b = 1.0 / 6.0 - t2 / 120.0 * (1.0 - t2 / 42.0 * (1.0 - t2 / 72.0));
  } else {
    const double sin_half = std::sin(0.5 * theta);
    a = 2.0 * sin_half * sin_half / t2;
    b = (theta - std::sin(theta)) / (t2 * theta);
  }
  return Eigen::Matrix3d::Identity() + a * W + b * W * W;
}

Eigen::Matrix3d LeftJacobianInverseSO3(const Eigen::Vector3d& omega) {
  const double theta = omega.norm();
  const Eigen::Matrix3d W = SkewSymmetric(omega);
  if (theta < 1e-6) return Eigen::Matrix3d::Identity() - 0.5 * W + W * W / 12.0;
  const double t2 = theta * theta;
  const double half = 0.5 * theta;
  const double cot_term = (1.0 - half * std::cos(half) / std::sin(half)) / t2;
  return Eigen::Matrix3d::Identity() - 0.5 * W + cot_term * W * W;
}

double AngularDistance(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return a.angularDistance(b);
}

}  // namespace lcv::slam
