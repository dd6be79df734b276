#include "slam/camera/fisheye.h"

#include <algorithm>
#include <cmath>

#include "slam/util/error.h"

namespace lcv::slam {
namespace {

// At theta = pi the whole ray behind the camera maps to a circle: stop just before it.
constexpr double kAngleCapRad = M_PI - 1e-6;
// Below this angle from the axis the projection uses its Taylor limit (r^2 would lose digits).
constexpr double kAxisAngleRad = 1e-6;

double AngleSlope(double theta, double k1, double k2, double k3, double k4) {
  const double t2 = theta * theta;
  return 1.0 + t2 * (3.0 * k1 + t2 * (5.0 * k2 + t2 * (7.0 * k3 + t2 * 9.0 * k4)));
}

}  // namespace

double FisheyeCamera::MaxValidAngle(const std::array<double, 5>& distortion) {
  const double k1 = distortion[0], k2 = distortion[1], k3 = distortion[2], k4 = distortion[3];
  constexpr int kSteps = 2000;
  double theta_prev = 0.0;
  for (int i = 1; i <= kSteps; ++i) {
    const double theta = kAngleCapRad * i / kSteps;
    if (!(AngleSlope(theta, k1, k2, k3, k4) > 0.0)) {
      double lo = theta_prev, hi = theta;
      for (int j = 0; j < 100; ++j) {
        const double mid = 0.5 * (lo + hi);
        (AngleSlope(mid, k1, k2, k3, k4) > 0.0 ? lo : hi) = mid;
      }
      return lo;
    }
    theta_prev = theta;
  }
  return kAngleCapRad;
}

FisheyeCamera::FisheyeCamera(const CameraParams& params) : Camera(params) {
  LCV_CHECK(params.model == CameraModel::kFisheye) << CameraModelName(params.model);
  const std::optional<std::string> problem = params.Problem();
  LCV_CHECK(!problem) << *problem;
  fx_ = params.fx;
  fy_ = params.fy;
  cx_ = params.cx;
  cy_ = params.cy;
  k1_ = params.distortion[0];
  k2_ = params.distortion[1];
  k3_ = params.distortion[2];
  k4_ = params.distortion[3];
  max_theta_rad_ = MaxValidAngle(params.distortion);
  max_theta_d_ = DistortAngle(max_theta_rad_, nullptr);
}

double FisheyeCamera::DistortAngle(double theta, double* d_theta_d) const {
  const double t2 = theta * theta;
  if (d_theta_d != nullptr) *d_theta_d = AngleSlope(theta, k1_, k2_, k3_, k4_);
  return theta * (1.0 + t2 * (k1_ + t2 * (k2_ + t2 * (k3_ + t2 * k4_))));
}

std::optional<Eigen::Vector2d> FisheyeCamera::ProjectImpl(
    const Eigen::Vector3d& p_in_cam, Eigen::Matrix<double, 2, 3>* J_px_p) const {
  const double x = p_in_cam.x(), y = p_in_cam.y(), z = p_in_cam.z();
  const double r2 = x * x + y * y;
  const double rho2 = r2 + z * z;
  if (!(rho2 > 0.0) || !std::isfinite(rho2)) return std::nullopt;  // origin, NaN or inf
  const double r = std::sqrt(r2);
  const double theta = std::atan2(r, z);
  if (!(theta < max_theta_rad_)) return std::nullopt;
  double d_theta_d;
  const double theta_d = DistortAngle(theta, &d_theta_d);
  // px = f * s * (x, y) + c with s = theta_d / r. Near the axis (then z > 0) its Taylor limit:
  // s = (1 + (k1 - 1/3) (r/z)^2) / z.
  const bool near_axis = theta < kAxisAngleRad;
  const double s = near_axis ? (1.0 + (k1_ - 1.0 / 3.0) * r2 / (z * z)) / z : theta_d / r;
  if (J_px_p != nullptr) {
    // ds/dx = q x, ds/dy = q y with q = (ds/dr) / r; ds/dz = -theta_d' / rho^2.
    const double q = near_axis ? 2.0 * (k1_ - 1.0 / 3.0) / (z * z * z)
                               : (d_theta_d * z / rho2 - s) / r2;
    const double s_z = -d_theta_d / rho2;
    *J_px_p << fx_ * (s + q * x * x), fx_ * q * x * y, fx_ * x * s_z,  //
        fy_ * q * x * y, fy_ * (s + q * y * y), fy_ * y * s_z;
  }
  return Eigen::Vector2d(fx_ * s * x + cx_, fy_ * s * y + cy_);
}

std::optional<Eigen::Vector3d> FisheyeCamera::UnprojectImpl(const Eigen::Vector2d& px) const {
  const Eigen::Vector2d pw((px.x() - cx_) / fx_, (px.y() - cy_) / fy_);
  const double theta_d = pw.norm();
  if (!(theta_d < max_theta_d_)) return std::nullopt;  // also NaN and inf
  if (theta_d == 0.0) return Eigen::Vector3d::UnitZ();
  // theta_d(theta) increases on [0, max_theta]: Newton kept inside a shrinking bracket, with a
  // bisection step whenever Newton would leave it.
  double lo = 0.0, hi = max_theta_rad_;
  double theta = std::min(theta_d, max_theta_rad_);
  for (int iteration = 0; iteration < 100; ++iteration) {
    double slope;
    const double f = DistortAngle(theta, &slope) - theta_d;
    if (f == 0.0) break;
    (f < 0.0 ? lo : hi) = theta;
    double next = slope > 0.0 ? theta - f / slope : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    const double step = std::abs(next - theta);
    theta = next;
    if (step < 1e-15 * (1.0 + theta) || hi - lo < 1e-15) break;
  }
  if (!(std::abs(DistortAngle(theta, nullptr) - theta_d) < 1e-10)) return std::nullopt;
  const double sin_theta = std::sin(theta);
  return Eigen::Vector3d(sin_theta * pw.x() / theta_d, sin_theta * pw.y() / theta_d,
                         std::cos(theta));
}

std::optional<Eigen::Vector2d> FisheyeCamera::Project(const Eigen::Vector3d& p_in_cam,
                                                      Eigen::Matrix<double, 2, 3>* J_px_p) const {
  return ProjectImpl(p_in_cam, J_px_p);
}

std::optional<Eigen::Vector3d> FisheyeCamera::Unproject(const Eigen::Vector2d& px) const {
  return UnprojectImpl(px);
}

void FisheyeCamera::ProjectBatch(const Eigen::Vector3d* p_in_cam, int count, Eigen::Vector2d* px,
                                 unsigned char* valid) const {
  for (int i = 0; i < count; ++i) {
    const std::optional<Eigen::Vector2d> projected = ProjectImpl(p_in_cam[i], nullptr);
    valid[i] = projected.has_value() ? 1 : 0;
    if (projected) px[i] = *projected;
  }
}

void FisheyeCamera::UnprojectBatch(const Eigen::Vector2d* px, int count,
                                   Eigen::Vector3d* bearings, unsigned char* valid) const {
  for (int i = 0; i < count; ++i) {
    const std::optional<Eigen::Vector3d> bearing = UnprojectImpl(px[i]);
    valid[i] = bearing.has_value() ? 1 : 0;
    if (bearing) bearings[i] = *bearing;
  }
}

}  // namespace lcv::slam
