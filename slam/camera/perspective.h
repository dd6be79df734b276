#pragma once
// Perspective (pinhole) camera with OpenCV's radial-tangential distortion {k1, k2, p1, p2, k3}.
//
// With (x, y) = (X / Z, Y / Z) the normalized coordinates of a camera-frame point and
// r^2 = x^2 + y^2:
//   x_d = x (1 + k1 r^2 + k2 r^4 + k3 r^6) + 2 p1 x y + p2 (r^2 + 2 x^2)
//   y_d = y (1 + k1 r^2 + k2 r^4 + k3 r^6) + p1 (r^2 + 2 y^2) + 2 p2 x y
//   px  = (fx x_d + cx, fy y_d + cy)
// exactly as cv::projectPoints.
//
// Valid region: a polynomial distortion folds back beyond some radius (the image of a point far
// outside the field of view lands inside the image again). The model is used only where the
// radial part r (1 + k1 r^2 + k2 r^4 + k3 r^6) still grows with r, up to MaxUndistortedRadius(),
// computed once at construction; Project() refuses points beyond it and Unproject() refuses
// pixels whose undistortion does not converge inside it. MaxViewAngle() = atan of that radius
// (below 90 degrees).

#include <array>
#include <optional>

#include <Eigen/Core>

#include "slam/camera/camera.h"

namespace lcv::slam {

class PerspectiveCamera final : public Camera {
 public:
  // Precondition: params.model == kPerspective and !params.Problem() (checked).
  explicit PerspectiveCamera(const CameraParams& params);

  // Empty when p_in_cam.z() <= 0 or when the point lies beyond the valid radius.
  std::optional<Eigen::Vector2d> Project(const Eigen::Vector3d& p_in_cam,
                                         Eigen::Matrix<double, 2, 3>* J_px_p = nullptr)
      const override;
  // Undistorts by Newton's method to a residual below 1e-10 (normalized units). Empty when it
  // does not converge or converges outside the valid radius.
  std::optional<Eigen::Vector3d> Unproject(const Eigen::Vector2d& px) const override;
  double MaxViewAngle() const override { return max_view_angle_rad_; }

  void ProjectBatch(const Eigen::Vector3d* p_in_cam, int count, Eigen::Vector2d* px,
                    unsigned char* valid) const override;
  void UnprojectBatch(const Eigen::Vector2d* px, int count, Eigen::Vector3d* bearings,
                      unsigned char* valid) const override;

  // Largest normalized radius r = |(X/Z, Y/Z)| at which the radial distortion is still
  // monotonic, capped at tan(89.9 deg). distortion = {k1, k2, p1, p2, k3}.
  static double MaxUndistortedRadius(const std::array<double, 5>& distortion);
  double max_undistorted_radius() const { return max_radius_; }

 private:
  // Normalized undistorted (x, y) -> normalized distorted, with d(distorted)/d(undistorted).
  Eigen::Vector2d Distort(const Eigen::Vector2d& xy, Eigen::Matrix2d* J) const;
  std::optional<Eigen::Vector2d> ProjectImpl(const Eigen::Vector3d& p_in_cam,
                                             Eigen::Matrix<double, 2, 3>* J_px_p) const;
  std::optional<Eigen::Vector3d> UnprojectImpl(const Eigen::Vector2d& px) const;

  double fx_, fy_, cx_, cy_;
  double k1_, k2_, p1_, p2_, k3_;
  bool has_distortion_;
  double max_radius_;
  double max_radius_sq_;
  double max_view_angle_rad_;
};

}  // namespace lcv::slam
