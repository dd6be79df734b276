#pragma once
// 3D lines of a line cloud (paper Sec. 3.4): L = {p_L, d_L}, anchor point p_L and unit direction
// d_L. A published line replaces a hidden 3D point X_L somewhere on it.

#include <optional>

#include <Eigen/Core>

namespace lcv::slam {

struct Line3d {
  Eigen::Vector3d anchor = Eigen::Vector3d::Zero();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();  // unit norm

  Line3d() = default;
  Line3d(const Eigen::Vector3d& a, const Eigen::Vector3d& d) : anchor(a), direction(d) {}

  Eigen::Vector3d PointAt(double s) const { return anchor + s * direction; }
  // Signed position of the foot of the perpendicular from x, along the direction.
  double Parameter(const Eigen::Vector3d& x) const { return direction.dot(x - anchor); }
  Eigen::Vector3d Project(const Eigen::Vector3d& x) const { return PointAt(Parameter(x)); }
  // Component of (x - anchor) orthogonal to the line.
  Eigen::Vector3d Residual(const Eigen::Vector3d& x) const { return x - Project(x); }
  double Distance(const Eigen::Vector3d& x) const { return Residual(x).norm(); }
};

// Closest points between two lines: a.PointAt(s_a) and b.PointAt(s_b). Empty when the lines are
// parallel to within |sin(angle)| < parallel_tolerance.
struct ClosestPoints {
  double s_a = 0.0;
  double s_b = 0.0;
  double distance = 0.0;
};
std::optional<ClosestPoints> ClosestPointsBetweenLines(const Line3d& a, const Line3d& b,
                                                      double parallel_tolerance = 1e-9);

// The paper's eq. (1): Omega_L = ((I - d d^T) Sigma_X (I - d d^T))^+, the information of a line
// converted from a point with covariance Sigma_X. Rank 2 for a full-rank Sigma_X, symmetric PSD,
// with d in its null space: the line carries no information along itself.
// Precondition: direction is unit, covariance symmetric positive definite.
Eigen::Matrix3d LineInformation(const Eigen::Vector3d& direction,
                                const Eigen::Matrix3d& point_covariance);

// Symmetric square root S of a symmetric PSD matrix (S S = information, S = S^T), through the
// eigen-decomposition; negative eigenvalues from rounding are clamped to 0. Rank is kept: the
// square root of a rank-2 Omega_L has the same null space.
Eigen::Matrix3d SqrtInformation(const Eigen::Matrix3d& information);

// Omega_L of a line whose direction turned from `from` to `to`: rotated by the smallest rotation
// between them (R Omega_L R^T, symmetrized), so that the new direction is in its null space (the
// map invariant). Directions need not be unit; opposite ones turn half a turn about an
// orthogonal axis.
Eigen::Matrix3d TurnLineInformation(const Eigen::Matrix3d& information,
                                    const Eigen::Vector3d& from, const Eigen::Vector3d& to);

// A uniformly distributed unit vector from two uniform numbers u, v in [0, 1).
Eigen::Vector3d UniformUnitVector(double u, double v);

}  // namespace lcv::slam
