#include "slam/camera/equirectangular.h"

#include <cmath>

#include "slam/util/approx_atan2.h"
#include "slam/util/error.h"

namespace lcv::slam {

EquirectangularCamera::EquirectangularCamera(const CameraParams& params) : Camera(params) {
  LCV_CHECK(params.model == CameraModel::kEquirectangular) << CameraModelName(params.model);
  const std::optional<std::string> problem = params.Problem();
  LCV_CHECK(!problem) << *problem;
  cols_ = params.cols;
  rows_ = params.rows;
}

double EquirectangularCamera::MaxViewAngle() const { return M_PI; }

std::optional<Eigen::Vector2d> EquirectangularCamera::ProjectImpl(
    const Eigen::Vector3d& p_in_cam, Eigen::Matrix<double, 2, 3>* J_px_p) const {
  const double x = p_in_cam.x(), y = p_in_cam.y(), z = p_in_cam.z();
  const double h2 = x * x + z * z;  // squared distance from the vertical axis
  if (!(h2 > 0.0) || !std::isfinite(h2) || !std::isfinite(y)) return std::nullopt;
  const double h = std::sqrt(h2);
  // ApproxAtan2 is within 2e-10 rad of std::atan2 (2e-8 px on a 640-column panorama) at about a
  // quarter of its cost: two libm atan2 were the largest part of a motion-only BA term.
  const double longitude = ApproxAtan2(x, z);
  // -asin(y / |p|), through atan2 for full accuracy near the poles.
  const double latitude = -ApproxAtan2(y, h);
  if (J_px_p != nullptr) {
    const double n2 = h2 + y * y;
    const double u_scale = cols_ / (2.0 * M_PI * h2);
    const double v_scale = rows_ / (M_PI * h * n2);
    *J_px_p << u_scale * z, 0.0, -u_scale * x,  //
        -v_scale * x * y, v_scale * h2, -v_scale * y * z;
  }
  return Eigen::Vector2d(cols_ * (0.5 + longitude / (2.0 * M_PI)),
                         rows_ * (0.5 - latitude / M_PI));
}

std::optional<Eigen::Vector2d> EquirectangularCamera::ProjectApprox(
    const Eigen::Vector3d& p_in_cam, const Eigen::Vector3d& tangent, double* px_per_unit) const {
  const double x = p_in_cam.x(), y = p_in_cam.y(), z = p_in_cam.z();
  const double h2 = x * x + z * z;
  if (!(h2 > 0.0) || !std::isfinite(h2) || !std::isfinite(y)) return std::nullopt;
  const double h = std::sqrt(h2);
  const double longitude = ApproxAtan2(x, z);
  const double latitude = -ApproxAtan2(y, h);
  // ProjectImpl's Jacobian rows times the tangent.
  const double n2 = h2 + y * y;
  const double du = cols_ / (2.0 * M_PI * h2) * (z * tangent.x() - x * tangent.z());
  const double dv =
      rows_ / (M_PI * h * n2) * (h2 * tangent.y() - y * (x * tangent.x() + z * tangent.z()));
  *px_per_unit = std::sqrt(du * du + dv * dv);
  return Eigen::Vector2d(cols_ * (0.5 + longitude / (2.0 * M_PI)),
                         rows_ * (0.5 - latitude / M_PI));
}

std::optional<Eigen::Vector3d> EquirectangularCamera::UnprojectImpl(
    const Eigen::Vector2d& px) const {
  if (!std::isfinite(px.x()) || !(px.y() >= 0.0 && px.y() <= rows_)) return std::nullopt;
  const double longitude = (px.x() / cols_ - 0.5) * 2.0 * M_PI;
  const double latitude = (0.5 - px.y() / rows_) * M_PI;
  const double cos_latitude = std::cos(latitude);
  return Eigen::Vector3d(cos_latitude * std::sin(longitude), -std::sin(latitude),
                         cos_latitude * std::cos(longitude));
}

std::optional<Eigen::Vector2d> EquirectangularCamera::Project(
    const Eigen::Vector3d& p_in_cam, Eigen::Matrix<double, 2, 3>* J_px_p) const {
  return ProjectImpl(p_in_cam, J_px_p);
}

std::optional<Eigen::Vector3d> EquirectangularCamera::Unproject(const Eigen::Vector2d& px) const {
  return UnprojectImpl(px);
}

void EquirectangularCamera::ProjectBatch(const Eigen::Vector3d* p_in_cam, int count,
                                         Eigen::Vector2d* px, unsigned char* valid) const {
  for (int i = 0; i < count; ++i) {
    const std::optional<Eigen::Vector2d> projected = ProjectImpl(p_in_cam[i], nullptr);
    valid[i] = projected.has_value() ? 1 : 0;
    if (projected) px[i] = *projected;
  }
}

void EquirectangularCamera::UnprojectBatch(const Eigen::Vector2d* px, int count,
                                           Eigen::Vector3d* bearings,
                                           unsigned char* valid) const {
  for (int i = 0; i < count; ++i) {
    const std::optional<Eigen::Vector3d> bearing = UnprojectImpl(px[i]);
    valid[i] = bearing.has_value() ? 1 : 0;
    if (bearing) bearings[i] = *bearing;
  }
}

}  // namespace lcv::slam
