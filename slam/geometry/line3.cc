#include "slam/geometry/line3.h"

#include <cmath>

#include <Eigen/Eigenvalues>

#include "slam/geometry/so3.h"

namespace lcv::slam {

Eigen::Matrix3d SqrtInformation(const Eigen::Matrix3d& information) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(0.5 * (information + information.transpose()));
  const Eigen::Vector3d root = eig.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  return eig.eigenvectors() * root.asDiagonal() * eig.eigenvectors().transpose();
}


std::optional<ClosestPoints> ClosestPointsBetweenLines(const Line3d& a, const Line3d& b,
                                                      double parallel_tolerance) {
  // Minimize |a.anchor + s_a d_a - b.anchor - s_b d_b|^2 with unit directions.
  const Eigen::Vector3d w = a.anchor - b.anchor;
  const double c = a.direction.dot(b.direction);
  // sin^2 of the angle from the cross product: 1 - c^2 rounds to 0 below ~1e-8 rad, which made
  // any parallel_tolerance under 1e-8 unreachable.
  const double denom = a.direction.cross(b.direction).squaredNorm();
  if (denom < parallel_tolerance * parallel_tolerance) return std::nullopt;
  const double da = a.direction.dot(w);
  const double db = b.direction.dot(w);
  ClosestPoints out;
  out.s_a = (c * db - da) / denom;
  out.s_b = (db - c * da) / denom;
  out.distance = (a.PointAt(out.s_a) - b.PointAt(out.s_b)).norm();
  return out;
}

Eigen::Matrix3d LineInformation(const Eigen::Vector3d& direction,
                                const Eigen::Matrix3d& point_covariance) {
  const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - direction * direction.transpose();
  const Eigen::Matrix3d projected = P * point_covariance * P;
  // Pseudo-inverse through the eigen-decomposition of the symmetric projected covariance; the
  // eigenvalue along d is zero up to rounding and is dropped by a relative threshold.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(0.5 * (projected + projected.transpose()));
  const Eigen::Vector3d values = eig.eigenvalues();
  const double threshold = 1e-12 * std::max(values.cwiseAbs().maxCoeff(), 1e-300);
  Eigen::Matrix3d info = Eigen::Matrix3d::Zero();
  for (int i = 0; i < 3; ++i) {
    if (values(i) > threshold) {
      const Eigen::Vector3d u = eig.eigenvectors().col(i);
      info += u * u.transpose() / values(i);
    }
  }
  // Remove the residual component along d left by rounding, and symmetrize.
  info = P * info * P;
  return 0.5 * (info + info.transpose());
}

Eigen::Vector3d UniformUnitVector(double u, double v) {
  const double z = 1.0 - 2.0 * u;
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  const double phi = 2.0 * M_PI * v;
  return Eigen::Vector3d(r * std::cos(phi), r * std::sin(phi), z);
}

Eigen::Matrix3d TurnLineInformation(const Eigen::Matrix3d& information,
                                    const Eigen::Vector3d& from, const Eigen::Vector3d& to) {
  const Eigen::Vector3d a = from.normalized(), b = to.normalized();
  const Eigen::Vector3d axis = a.cross(b);
  const double sin_angle = axis.norm();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  if (sin_angle >= 1e-15) {
    R = ExpSO3(axis * (std::atan2(sin_angle, a.dot(b)) / sin_angle)).toRotationMatrix();
  } else if (a.dot(b) < 0.0) {
    const Eigen::Vector3d helper =
        std::abs(a.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    R = ExpSO3(M_PI * a.cross(helper).normalized()).toRotationMatrix();
  }
  const Eigen::Matrix3d turned = R * information * R.transpose();
  return 0.5 * (turned + turned.transpose());
}

}  // namespace lcv::slam
