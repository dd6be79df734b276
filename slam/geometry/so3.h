#pragma once
// Rotation helpers on SO(3). Tangent vectors are axis-angle vectors (radians).

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace lcv::slam {

// [v]x such that [v]x * w = v.cross(w).
inline Eigen::Matrix3d SkewSymmetric(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

// exp: axis-angle -> unit quaternion. Exact near zero (Taylor series below 1e-8 rad).
Eigen::Quaterniond ExpSO3(const Eigen::Vector3d& omega);
// log: unit quaternion -> axis-angle with norm in [0, pi].
Eigen::Vector3d LogSO3(const Eigen::Quaterniond& q);
// Left Jacobian of SO(3) at omega (maps tangent increments to translation in SE(3) exp).
Eigen::Matrix3d LeftJacobianSO3(const Eigen::Vector3d& omega);
Eigen::Matrix3d LeftJacobianInverseSO3(const Eigen::Vector3d& omega);

// Angle in radians between two rotations, in [0, pi].
double AngularDistance(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b);

}  // namespace lcv::slam
