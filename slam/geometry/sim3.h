#pragma once
// Similarity transform b_from_a: x_in_b = scale * rotation * x_in_a + translation.
// Used for monocular scale drift (loop closing, pose graph) and for registering a client map to
// a server line cloud (P4L / P3P). Tangent vector: [v; omega; sigma] with scale = exp(sigma).

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "slam/geometry/rigid3.h"

namespace lcv::slam {

using Vector7d = Eigen::Matrix<double, 7, 1>;

struct Sim3d {
  double scale = 1.0;
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Sim3d() = default;
  Sim3d(double s, const Eigen::Quaterniond& r, const Eigen::Vector3d& t)
      : scale(s), rotation(r), translation(t) {}
  explicit Sim3d(const Rigid3d& rigid) : scale(1.0), rotation(rigid.rotation),
                                         translation(rigid.translation) {}

  Eigen::Vector3d operator*(const Eigen::Vector3d& x_in_a) const {
    return scale * (rotation * x_in_a) + translation;
  }
  // c_from_a = c_from_b * b_from_a.
  Sim3d operator*(const Sim3d& b_from_a) const {
    return Sim3d(scale * b_from_a.scale, rotation * b_from_a.rotation,
                 scale * (rotation * b_from_a.translation) + translation);
  }
  Sim3d Inverse() const {
    const Eigen::Quaterniond inv = rotation.conjugate();
    return Sim3d(1.0 / scale, inv, -(inv * translation) / scale);
  }
  Eigen::Matrix4d ToMatrix() const {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = scale * rotation.toRotationMatrix();
    m.topRightCorner<3, 1>() = translation;
    return m;
  }
  // Exponential of [v; omega; sigma] (Strasdat 2012, eq. in appendix).
  static Sim3d Exp(const Vector7d& delta);
  Vector7d Log() const;
};

// Apply a similarity to a camera pose: given world2_from_world1 (S) and cam_from_world1 (T),
// returns cam_from_world2 with the scale removed from the camera (its centre moves with S).
Rigid3d TransformPose(const Sim3d& world2_from_world1, const Rigid3d& cam_from_world1);

}  // namespace lcv::slam
