#pragma once
// Rigid transform b_from_a: x_in_b = rotation * x_in_a + translation (COLMAP's convention).
//
// Storage: unit quaternion (Eigen order x,y,z,w in memory) and translation. Names follow the
// frames: cam_from_world maps world points into the camera frame; its inverse world_from_cam has
// the camera centre as translation.
//
// Perturbation (used by every Jacobian in the project, defined here once): a 6-vector
// delta = [v; omega] (translation part first, as Sophus) updates a pose on the left,
//   T <- Exp(delta) * T,
// where Exp is the SE(3) exponential below.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "slam/geometry/so3.h"

namespace lcv::slam {

using Vector6d = Eigen::Matrix<double, 6, 1>;

struct Rigid3d {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Rigid3d() = default;
  Rigid3d(const Eigen::Quaterniond& r, const Eigen::Vector3d& t) : rotation(r), translation(t) {}

  Eigen::Vector3d operator*(const Eigen::Vector3d& x_in_a) const {
    return rotation * x_in_a + translation;
  }
  // c_from_a = c_from_b * b_from_a.
  Rigid3d operator*(const Rigid3d& b_from_a) const {
    return Rigid3d(rotation * b_from_a.rotation, rotation * b_from_a.translation + translation);
  }
  Rigid3d Inverse() const {
    const Eigen::Quaterniond inv = rotation.conjugate();
    return Rigid3d(inv, -(inv * translation));
  }
  Eigen::Matrix3d RotationMatrix() const { return rotation.toRotationMatrix(); }
  // 3x4 [R | t].
  Eigen::Matrix<double, 3, 4> ToMatrix() const {
    Eigen::Matrix<double, 3, 4> m;
    m.leftCols<3>() = RotationMatrix();
    m.col(3) = translation;
    return m;
  }
  static Rigid3d FromMatrix(const Eigen::Matrix<double, 3, 4>& m) {
    Eigen::Quaterniond q(m.leftCols<3>());
    q.normalize();
    return Rigid3d(q, m.col(3));
  }
  // For a cam_from_world pose: the camera centre in world coordinates.
  Eigen::Vector3d Center() const { return -(rotation.conjugate() * translation); }

  // SE(3) exponential of delta = [v; omega].
  static Rigid3d Exp(const Vector6d& delta) {
    const Eigen::Vector3d omega = delta.tail<3>();
    return Rigid3d(ExpSO3(omega), LeftJacobianSO3(omega) * delta.head<3>());
  }
  // Inverse of Exp.
  Vector6d Log() const {
    const Eigen::Vector3d omega = LogSO3(rotation);
    Vector6d out;
    out.head<3>() = LeftJacobianInverseSO3(omega) * translation;
    out.tail<3>() = omega;
    return out;
  }
};

}  // namespace lcv::slam
