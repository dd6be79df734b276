#pragma once
// Equirectangular (360-degree panorama) camera, stella_vslam's convention (y down):
//   longitude = atan2(X, Z)            in (-pi, pi], 0 straight ahead, positive to the right
//   latitude  = -asin(Y / |p|)         in [-pi/2, pi/2], positive up
//   px        = (cols (0.5 + longitude / (2 pi)), rows (0.5 - latitude / pi))
// The whole sphere images: Project() fails only at the origin and exactly at the poles
// (X = Z = 0), where longitude and the Jacobian are undefined. The image wraps horizontally:
// the seam is straight behind the camera (longitude = +-pi).

#include <optional>

#include <Eigen/Core>

#include "slam/camera/camera.h"

namespace lcv::slam {

class EquirectangularCamera final : public Camera {
 public:
  // Precondition: params.model == kEquirectangular and !params.Problem() (checked).
  explicit EquirectangularCamera(const CameraParams& params);

  std::optional<Eigen::Vector2d> Project(const Eigen::Vector3d& p_in_cam,
                                         Eigen::Matrix<double, 2, 3>* J_px_p = nullptr)
      const override;
  // Any column (the image wraps); empty for rows outside [0, rows].
  std::optional<Eigen::Vector3d> Unproject(const Eigen::Vector2d& px) const override;
  double MaxViewAngle() const override;  // pi

  // Project() of p_in_cam and, instead of the Jacobian, the pixel speed |J_px_p * tangent| along
  // a direction: for the 2D point - 3D line search, which walks bearings along a line. Both take
  // longitude and latitude with ApproxAtan2 (slam/util/approx_atan2.h: within 2e-10 rad of libm's
  // atan2, 2e-8 px at 640 columns, a quarter of its cost), so their pixels are the same.
  std::optional<Eigen::Vector2d> ProjectApprox(const Eigen::Vector3d& p_in_cam,
                                               const Eigen::Vector3d& tangent,
                                               double* px_per_unit) const;

  void ProjectBatch(const Eigen::Vector3d* p_in_cam, int count, Eigen::Vector2d* px,
                    unsigned char* valid) const override;
  void UnprojectBatch(const Eigen::Vector2d* px, int count, Eigen::Vector3d* bearings,
                      unsigned char* valid) const override;

 private:
  std::optional<Eigen::Vector2d> ProjectImpl(const Eigen::Vector3d& p_in_cam,
                                             Eigen::Matrix<double, 2, 3>* J_px_p) const;
  std::optional<Eigen::Vector3d> UnprojectImpl(const Eigen::Vector2d& px) const;

  double cols_, rows_;
};

}  // namespace lcv::slam
