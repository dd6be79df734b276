#include "slam/camera/perspective.h"

#include <algorithm>
#include <cmath>

#include "slam/util/error.h"

namespace lcv::slam {
namespace {

// Beyond ~89.9 degrees a perspective image is meaningless and r^6 terms start to overflow.
constexpr double kMaxHalfFovRad = 89.9 * M_PI / 180.0;

// d/dr of the radial map r (1 + k1 r^2 + k2 r^4 + k3 r^6).
double RadialSlope(double r, double k1, double k2, double k3) {
  const double r2 = r * r;
  return 1.0 + r2 * (3.0 * k1 + r2 * (5.0 * k2 + r2 * 7.0 * k3));
}

}  // namespace

double PerspectiveCamera::MaxUndistortedRadius(const std::array<double, 5>& distortion) {
  const double k1 = distortion[0], k2 = distortion[1], k3 = distortion[4];
  const double r_cap = std::tan(kMaxHalfFovRad);
  if (k1 == 0.0 && k2 == 0.0 && k3 == 0.0) return r_cap;
  // Walk outwards in angle (uniform steps resolve both small and large radii), then bisect the
  // first sign change of the slope.
  constexpr int kSteps = 2000;
  double r_prev = 0.0;
  for (int i = 1; i <= kSteps; ++i) {
    const double r = std::tan(kMaxHalfFovRad * i / kSteps);
    if (!(RadialSlope(r, k1, k2, k3) > 0.0)) {
      double lo = r_prev, hi = r;
      for (int j = 0; j < 100; ++j) {
        const double mid = 0.5 * (lo + hi);
        (RadialSlope(mid, k1, k2, k3) > 0.0 ? lo : hi) = mid;
      }
      return lo;
    }
    r_prev = r;
  }
  return r_cap;
}

PerspectiveCamera::PerspectiveCamera(const CameraParams& params) : Camera(params) {
  LCV_CHECK(params.model == CameraModel::kPerspective) << CameraModelName(params.model);
  const std::optional<std::string> problem = params.Problem();
  LCV_CHECK(!problem) << *problem;
  fx_ = params.fx;
  fy_ = params.fy;
  cx_ = params.cx;
  cy_ = params.cy;
  k1_ = params.distortion[0];
  k2_ = params.distortion[1];
  p1_ = params.distortion[2];
  p2_ = params.distortion[3];
  k3_ = params.distortion[4];
  has_distortion_ = k1_ != 0.0 || k2_ != 0.0 || p1_ != 0.0 || p2_ != 0.0 || k3_ != 0.0;
  max_radius_ = MaxUndistortedRadius(params.distortion);
  max_radius_sq_ = max_radius_ * max_radius_;
  max_view_angle_rad_ = std::atan(max_radius_);
}

Eigen::Vector2d PerspectiveCamera::Distort(const Eigen::Vector2d& xy, Eigen::Matrix2d* J) const {
  const double x = xy.x(), y = xy.y();
  const double x2 = x * x, y2 = y * y, xy2 = 2.0 * x * y;
  const double r2 = x2 + y2;
  const double radial = 1.0 + r2 * (k1_ + r2 * (k2_ + r2 * k3_));
  const Eigen::Vector2d distorted(x * radial + p1_ * xy2 + p2_ * (r2 + 2.0 * x2),
                                  y * radial + p1_ * (r2 + 2.0 * y2) + p2_ * xy2);
  if (J != nullptr) {
    const double d_radial_d_r2 = k1_ + r2 * (2.0 * k2_ + r2 * 3.0 * k3_);
    const double cross = xy2 * d_radial_d_r2 + 2.0 * (p1_ * x + p2_ * y);
    (*J)(0, 0) = radial + 2.0 * x2 * d_radial_d_r2 + 2.0 * p1_ * y + 6.0 * p2_ * x;
    (*J)(0, 1) = cross;
    (*J)(1, 0) = cross;
    (*J)(1, 1) = radial + 2.0 * y2 * d_radial_d_r2 + 6.0 * p1_ * y + 2.0 * p2_ * x;
  }
  return distorted;
}

std::optional<Eigen::Vector2d> PerspectiveCamera::ProjectImpl(
    const Eigen::Vector3d& p_in_cam, Eigen::Matrix<double, 2, 3>* J_px_p) const {
  if (!(p_in_cam.z() > 0.0)) return std::nullopt;  // behind, on the image plane, or NaN
  const double inv_z = 1.0 / p_in_cam.z();
  const Eigen::Vector2d xy(p_in_cam.x() * inv_z, p_in_cam.y() * inv_z);
  if (!(xy.squaredNorm() <= max_radius_sq_)) return std::nullopt;
  Eigen::Matrix2d J_d_xy;
  const Eigen::Vector2d distorted = Distort(xy, J_px_p != nullptr ? &J_d_xy : nullptr);
  if (J_px_p != nullptr) {
    // d(xy)/dp = [1/z, 0, -x/z; 0, 1/z, -y/z].
    Eigen::Matrix<double, 2, 3> J_xy_p;
    J_xy_p << inv_z, 0.0, -xy.x() * inv_z, 0.0, inv_z, -xy.y() * inv_z;
    *J_px_p = J_d_xy * J_xy_p;
    J_px_p->row(0) *= fx_;
    J_px_p->row(1) *= fy_;
  }
  return Eigen::Vector2d(fx_ * distorted.x() + cx_, fy_ * distorted.y() + cy_);
}

std::optional<Eigen::Vector3d> PerspectiveCamera::UnprojectImpl(const Eigen::Vector2d& px) const {
  const Eigen::Vector2d target((px.x() - cx_) / fx_, (px.y() - cy_) / fy_);
  if (!target.allFinite()) return std::nullopt;
  if (!has_distortion_) {
    if (!(target.squaredNorm() <= max_radius_sq_)) return std::nullopt;
    return Eigen::Vector3d(target.x(), target.y(), 1.0).normalized();
  }
  // Newton on distort(xy) = target from xy = target (the distortion is a small perturbation of
  // the identity near the centre). Steps that leave the valid disc are halved: outside it the
  // map folds and Newton would converge to the wrong preimage.
  // Far outside the image (up to 89.9 degrees) a strong distortion can need ~50 iterations to
  // come back to the quadratic regime; the tolerance is relative there since the distorted
  // coordinates themselves reach 1e6.
  constexpr int kMaxIterations = 100;
  const double tolerance = 1e-10 * std::max(1.0, target.norm());  // ~1e-7 px at f = 1000 px
  Eigen::Vector2d xy = target;
  if (xy.squaredNorm() > max_radius_sq_) xy *= max_radius_ / xy.norm() * 0.5;
  Eigen::Matrix2d J;
  double residual_norm = 0.0;
  for (int iteration = 0; iteration < kMaxIterations; ++iteration) {
    const Eigen::Vector2d residual = Distort(xy, &J) - target;
    residual_norm = residual.norm();
    if (residual_norm < 1e-16 * (1.0 + target.norm())) break;
    const double det = J(0, 0) * J(1, 1) - J(0, 1) * J(1, 0);
    if (!(std::abs(det) > 1e-12)) return std::nullopt;
    Eigen::Vector2d step;
    step << (J(1, 1) * residual.x() - J(0, 1) * residual.y()) / det,
        (J(0, 0) * residual.y() - J(1, 0) * residual.x()) / det;
    Eigen::Vector2d next = xy - step;
    for (int halving = 0; halving < 30 && next.squaredNorm() > max_radius_sq_; ++halving) {
      step *= 0.5;
      next = xy - step;
    }
    xy = next;
    if (step.norm() < 1e-14 * (1.0 + xy.norm())) {
      residual_norm = (Distort(xy, nullptr) - target).norm();
      break;
    }
  }
  if (!(residual_norm < tolerance) || !(xy.squaredNorm() <= max_radius_sq_)) {
    return std::nullopt;
  }
  return Eigen::Vector3d(xy.x(), xy.y(), 1.0).normalized();
}

std::optional<Eigen::Vector2d> PerspectiveCamera::Project(const Eigen::Vector3d& p_in_cam,
                                                          Eigen::Matrix<double, 2, 3>* J_px_p)
    const {
  return ProjectImpl(p_in_cam, J_px_p);
}

std::optional<Eigen::Vector3d> PerspectiveCamera::Unproject(const Eigen::Vector2d& px) const {
  return UnprojectImpl(px);
}

void PerspectiveCamera::ProjectBatch(const Eigen::Vector3d* p_in_cam, int count,
                                     Eigen::Vector2d* px, unsigned char* valid) const {
  for (int i = 0; i < count; ++i) {
    const std::optional<Eigen::Vector2d> projected = ProjectImpl(p_in_cam[i], nullptr);
    valid[i] = projected.has_value() ? 1 : 0;
    if (projected) px[i] = *projected;
  }
}

void PerspectiveCamera::UnprojectBatch(const Eigen::Vector2d* px, int count,
                                       Eigen::Vector3d* bearings, unsigned char* valid) const {
  for (int i = 0; i < count; ++i) {
    const std::optional<Eigen::Vector3d> bearing = UnprojectImpl(px[i]);
    valid[i] = bearing.has_value() ? 1 : 0;
    if (bearing) bearings[i] = *bearing;
  }
}

}  // namespace lcv::slam
