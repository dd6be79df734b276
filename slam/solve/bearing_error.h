#pragma once
// Reprojection errors on unit bearing vectors, so that one threshold means the same for
// perspective, fisheye and equirectangular cameras (STYLE.md 2).
//
// Units: radians. A pixel threshold converts as angle ~ pixels / focal_px (for an
// equirectangular image of width W, focal_px = W / (2 pi)). Example: 2 px at fx = 718 is
// ~0.0028 rad.
//
// The "chord" error |p/|p| - b| equals 2 sin(angle / 2): it is the angle to within 1% below
// 0.35 rad, is cheap (one sqrt), and grows monotonically up to 2 for a point behind the
// bearing, so a point on the wrong side of the camera is always an outlier.

#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace lcv::slam {

// Angle in radians between the unit bearing b and the direction of the point p (same frame),
// in [0, pi]. pi/2 for p at the origin.
inline double AngularError(const Eigen::Vector3d& bearing, const Eigen::Vector3d& p) {
  return std::atan2(bearing.cross(p).norm(), bearing.dot(p));
}

// |p/|p| - b|^2 (= 4 sin^2(angle/2), ~ angle^2), the squared error used by RANSAC and the
// checks. 4 (the maximum) for p at the origin.
inline double SquaredChordError(const Eigen::Vector3d& bearing, const Eigen::Vector3d& p) {
  const double norm = p.norm();
  if (!(norm > 0.0)) return 4.0;
  return (p / norm - bearing).squaredNorm();
}

// Orthonormal basis (columns) of the plane tangent to the unit sphere at bearing b: b is
// orthogonal to both columns. Continuous except near one direction (b = -x), chosen so that it
// is smooth around the optical axis +z.
inline Eigen::Matrix<double, 3, 2> TangentBasis(const Eigen::Vector3d& bearing) {
  // Householder-like construction from the axis farthest from the bearing.
  Eigen::Vector3d helper = std::abs(bearing.x()) < 0.9 ? Eigen::Vector3d::UnitX()
                                                        : Eigen::Vector3d::UnitY();
  Eigen::Matrix<double, 3, 2> basis;
  basis.col(0) = (helper - bearing.dot(helper) * bearing).normalized();
  basis.col(1) = bearing.cross(basis.col(0));
  return basis;
}

// Tangent-plane error: the 2-vector basis^T * (p/|p|) for basis = TangentBasis(bearing), whose
// norm is sin(angle) for points in front (and shrinks again behind: check the sign of
// bearing.dot(p) where it matters). Used by the Gauss-Newton refiners (smooth, 2 residuals).
inline Eigen::Vector2d TangentError(const Eigen::Matrix<double, 3, 2>& basis,
                                    const Eigen::Vector3d& p) {
  return basis.transpose() * p.normalized();
}

}  // namespace lcv::slam
