#pragma once
// Fisheye camera, Kannala-Brandt model as OpenCV's cv::fisheye, {k1, k2, k3, k4}.
//
// For a camera-frame point p = (X, Y, Z) with r = sqrt(X^2 + Y^2):
//   theta   = atan2(r, Z)                      angle from the optical axis, in [0, pi]
//   theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8)
//   px      = (fx theta_d X / r + cx, fy theta_d Y / r + cy)
// theta is taken with atan2, so points with Z <= 0 project too: lenses with a field of view
// beyond 180 degrees work. On the optical axis (r -> 0) the limit px = (cx, cy) and the pinhole
// Jacobian diag(fx / Z, fy / Z) are used.
//
// Valid region: the model is invertible only where theta_d(theta) increases. The first angle at
// which d(theta_d)/d(theta) reaches zero (capped just below pi, where the model degenerates to a
// circle) is computed at construction and returned by MaxViewAngle(); Project() refuses points
// beyond it and Unproject() pixels beyond its image radius.

#include <array>
#include <optional>

#include <Eigen/Core>

#include "slam/camera/camera.h"

namespace lcv::slam {

class FisheyeCamera final : public Camera {
 public:
  // Precondition: params.model == kFisheye and !params.Problem() (checked).
  explicit FisheyeCamera(const CameraParams& params);

  // Empty at the origin and for angles theta >= MaxViewAngle().
  std::optional<Eigen::Vector2d> Project(const Eigen::Vector3d& p_in_cam,
                                         Eigen::Matrix<double, 2, 3>* J_px_p = nullptr)
      const override;
  // Solves theta from theta_d (safeguarded Newton). Empty at and beyond the valid image radius
  // theta_d(MaxViewAngle()), so that every bearing returned projects back.
  std::optional<Eigen::Vector3d> Unproject(const Eigen::Vector2d& px) const override;
  double MaxViewAngle() const override { return max_theta_rad_; }

  void ProjectBatch(const Eigen::Vector3d* p_in_cam, int count, Eigen::Vector2d* px,
                    unsigned char* valid) const override;
  void UnprojectBatch(const Eigen::Vector2d* px, int count, Eigen::Vector3d* bearings,
                      unsigned char* valid) const override;

  // First angle (radians) where d(theta_d)/d(theta) = 0, or pi - 1e-6 when there is none.
  // distortion = {k1, k2, k3, k4, unused}.
  static double MaxValidAngle(const std::array<double, 5>& distortion);

 private:
  // theta_d(theta) and its derivative.
  double DistortAngle(double theta, double* d_theta_d) const;
  std::optional<Eigen::Vector2d> ProjectImpl(const Eigen::Vector3d& p_in_cam,
                                             Eigen::Matrix<double, 2, 3>* J_px_p) const;
  std::optional<Eigen::Vector3d> UnprojectImpl(const Eigen::Vector2d& px) const;

  double fx_, fy_, cx_, cy_;
  double k1_, k2_, k3_, k4_;
  double max_theta_rad_;
  double max_theta_d_;  // theta_d(max_theta_rad_)
};

}  // namespace lcv::slam
