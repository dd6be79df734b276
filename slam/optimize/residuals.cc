#include "slam/optimize/residuals.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "slam/geometry/so3.h"

namespace lcv::slam {

bool ReprojectionResidual(const Camera& camera, const Rigid3d& cam_from_world,
                          const Eigen::Vector3d& p_in_world, const Eigen::Vector2d& observed_px,
                          Eigen::Vector2d* residual_px, Matrix26d* J_r_pose,
                          Matrix23d* J_r_point) {
  const Eigen::Matrix3d R = cam_from_world.RotationMatrix();
  const Eigen::Vector3d p_in_cam = R * p_in_world + cam_from_world.translation;
  Matrix23d J_px_p;
  const bool want_jacobian = J_r_pose != nullptr || J_r_point != nullptr;
  const std::optional<Eigen::Vector2d> px =
      camera.Project(p_in_cam, want_jacobian ? &J_px_p : nullptr);
  if (!px) return false;
  *residual_px = *px - observed_px;
  if (J_r_pose) {
    // Exp(delta) * T moves p_in_cam by v + omega x p_in_cam.
    J_r_pose->leftCols<3>() = J_px_p;
    J_r_pose->rightCols<3>() = -J_px_p * SkewSymmetric(p_in_cam);
  }
  if (J_r_point) *J_r_point = J_px_p * R;
  return true;
}

void PointToLineResidual(const Eigen::Vector3d& restored_point, const Line3d& line,
                         const Eigen::Matrix3d& sqrt_information, Eigen::Vector3d* residual,
                         Eigen::Matrix3d* J_r_point, Matrix34d* J_r_line) {
  const Eigen::Vector3d& d = line.direction;
  const Eigen::Vector3d offset = restored_point - line.anchor;
  const double along = d.dot(offset);
  const Eigen::Vector3d orthogonal = offset - along * d;  // (I - d d^T) (X' - p_L)
  *residual = sqrt_information * orthogonal;
  if (J_r_point || J_r_line) {
    const Eigen::Matrix3d S_P =
        sqrt_information * (Eigen::Matrix3d::Identity() - d * d.transpose());
    if (J_r_point) *J_r_point = S_P;
    if (J_r_line) {
      const Matrix32d B = OrthonormalComplement(d);
      // Anchor moves by B alpha: r changes by -S P B alpha = -S B alpha (B is orthogonal to d).
      J_r_line->leftCols<2>() = -sqrt_information * B;
      // d moves by (B beta) x d = -[d]x B beta; d(P offset)/dd = -(d.offset) I - d offset^T.
      const Eigen::Matrix3d J_orth_d =
          -along * Eigen::Matrix3d::Identity() - d * offset.transpose();
      J_r_line->rightCols<2>() = sqrt_information * J_orth_d * (-SkewSymmetric(d) * B);
    }
  }
}

Matrix32d OrthonormalComplement(const Eigen::Vector3d& u) {
  // Helper axis: the coordinate axis least aligned with u, so the cross product is well
  // conditioned (|u x axis| >= sqrt(2/3)).
  const Eigen::Vector3d a = u.cwiseAbs();
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();
  if (a.x() <= a.y() && a.x() <= a.z()) {
    axis.x() = 1.0;
  } else if (a.y() <= a.z()) {
    axis.y() = 1.0;
  } else {
    axis.z() = 1.0;
  }
  Matrix32d B;
  B.col(0) = u.cross(axis).normalized();
  B.col(1) = u.cross(B.col(0));  // b1 x b2 = b1 x (u x b1) = u for unit u orthogonal to b1
  return B;
}

Line3d RetractLine(const Line3d& line, const Eigen::Vector4d& delta) {
  const Matrix32d B = OrthonormalComplement(line.direction);
  Line3d out;
  out.anchor = line.anchor + B * delta.head<2>();
  out.direction = (ExpSO3(B * delta.tail<2>()) * line.direction).normalized();
  return out;
}

namespace {

// m = a_c x d_c, the unnormalized normal of the plane through the camera centre and the line.
struct PlaneNormal {
  Eigen::Vector3d a_c;
  Eigen::Vector3d d_c;
  Eigen::Vector3d m;
  double norm = 0.0;
};

PlaneNormal ComputePlaneNormal(const Rigid3d& cam_from_world, const Line3d& line) {
  PlaneNormal out;
  out.a_c = cam_from_world * line.anchor;
  out.d_c = cam_from_world.rotation * line.direction;
  out.m = out.a_c.cross(out.d_c);
  out.norm = out.m.norm();
  return out;
}

bool Degenerate(const PlaneNormal& p) {
  return !(p.norm > 1e-12 * std::max(p.a_c.norm(), 1e-300));
}

}  // namespace

Eigen::Vector3d LinePlaneNormal(const Rigid3d& cam_from_world, const Line3d& line) {
  const PlaneNormal p = ComputePlaneNormal(cam_from_world, line);
  if (Degenerate(p)) return Eigen::Vector3d::Zero();
  return p.m / p.norm;
}

double VirtualObservationError(const Rigid3d& cam_from_world, const Line3d& line,
                               const Eigen::Vector3d& observed_normal) {
  const double e = 1.0 - LinePlaneNormal(cam_from_world, line).dot(observed_normal);
  return e * e;
}

bool VirtualObservationResidual(const Rigid3d& cam_from_world, const Line3d& line,
                                const Eigen::Vector3d& observed_normal,
                                Eigen::Vector2d* residual, Matrix26d* J_r_pose,
                                Matrix24d* J_r_line) {
  const PlaneNormal p = ComputePlaneNormal(cam_from_world, line);
  if (Degenerate(p)) return false;
  const Eigen::Vector3d n = p.m / p.norm;
  const Matrix32d B_v = OrthonormalComplement(observed_normal);
  *residual = B_v.transpose() * n;
  if (J_r_pose || J_r_line) {
    // dn/dm = (I - n n^T) / |m|; dm = -[d_c]x da_c + [a_c]x dd_c.
    const Eigen::Matrix<double, 2, 3> J_r_m =
        B_v.transpose() * (Eigen::Matrix3d::Identity() - n * n.transpose()) / p.norm;
    if (J_r_pose) {
      // da_c = v + omega x a_c, dd_c = omega x d_c: dm/dv = -[d_c]x and dm/domega = -[m]x
      // (a rotation of the camera turns the normal with it).
      J_r_pose->leftCols<3>() = -J_r_m * SkewSymmetric(p.d_c);
      J_r_pose->rightCols<3>() = -J_r_m * SkewSymmetric(p.m);
    }
    if (J_r_line) {
      const Eigen::Matrix3d R = cam_from_world.RotationMatrix();
      const Matrix32d B = OrthonormalComplement(line.direction);
      // Anchor: da_c = R B dalpha. Direction: dd_c = R (-[d]x B) dbeta.
      J_r_line->leftCols<2>() = -J_r_m * SkewSymmetric(p.d_c) * R * B;
      J_r_line->rightCols<2>() =
          J_r_m * SkewSymmetric(p.a_c) * R * (-SkewSymmetric(line.direction) * B);
    }
  }
  return true;
}

bool VirtualObservationAnchorJacobian(const Rigid3d& cam_from_world, const Line3d& line,
                                      const Eigen::Vector3d& observed_normal,
                                      Eigen::Matrix<double, 2, 3>* J_r_anchor) {
  const PlaneNormal p = ComputePlaneNormal(cam_from_world, line);
  if (Degenerate(p)) return false;
  const Eigen::Vector3d n = p.m / p.norm;
  const Matrix32d B_v = OrthonormalComplement(observed_normal);
  const Eigen::Matrix<double, 2, 3> J_r_m =
      B_v.transpose() * (Eigen::Matrix3d::Identity() - n * n.transpose()) / p.norm;
  // da_c = R dp_L, dm = -[d_c]x da_c.
  *J_r_anchor = -J_r_m * SkewSymmetric(p.d_c) * cam_from_world.RotationMatrix();
  return true;
}

Eigen::Matrix2d VirtualObservationInformation(const Rigid3d& cam_from_world, const Line3d& line,
                                              const Eigen::Vector3d& observed_normal,
                                              const Eigen::Matrix3d& line_information,
                                              double sigma_floor_rad) {
  const double floor_variance = sigma_floor_rad * sigma_floor_rad;
  Eigen::Matrix<double, 2, 3> J;
  if (!VirtualObservationAnchorJacobian(cam_from_world, line, observed_normal, &J)) {
    return Eigen::Matrix2d::Identity() / floor_variance;
  }
  // Sigma_perp = pinv(Omega_L) through the eigen-decomposition (rank 2 by construction).
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(line_information);
  Eigen::Matrix3d sigma_perp = Eigen::Matrix3d::Zero();
  const double largest = eig.eigenvalues().maxCoeff();
  for (int i = 0; i < 3; ++i) {
    const double v = eig.eigenvalues()(i);
    if (v > 1e-12 * largest && v > 0.0) {
      sigma_perp += eig.eigenvectors().col(i) * eig.eigenvectors().col(i).transpose() / v;
    }
  }
  Eigen::Matrix2d sigma_r = J * sigma_perp * J.transpose();
  sigma_r = 0.5 * (sigma_r + sigma_r.transpose());
  sigma_r.diagonal().array() += floor_variance;
  return sigma_r.inverse();
}

bool LineIntersectionResidual(const Line3d& moving, const Line3d& fixed, double* residual,
                              Eigen::Matrix<double, 1, 4>* J_r_line) {
  const Eigen::Vector3d c = moving.direction.cross(fixed.direction);
  const double norm = c.norm();
  if (norm < 1e-9) return false;
  const Eigen::Vector3d n = c / norm;
  const Eigen::Vector3d e = moving.anchor - fixed.anchor;
  *residual = e.dot(n);
  if (J_r_line) {
    const Matrix32d B = OrthonormalComplement(moving.direction);
    // Anchor: dp = B dalpha. Direction: dd = -[d]x B dbeta, dc = -[d_f]x dd,
    // dn = (I - n n^T) dc / |c|.
    J_r_line->leftCols<2>() = n.transpose() * B;
    J_r_line->rightCols<2>() = e.transpose() * (Eigen::Matrix3d::Identity() - n * n.transpose()) *
                               SkewSymmetric(fixed.direction) * SkewSymmetric(moving.direction) *
                               B / norm;
  }
  return true;
}

Eigen::Matrix<double, 6, 6> AdjointSE3(const Rigid3d& T) {
  const Eigen::Matrix3d R = T.RotationMatrix();
  Eigen::Matrix<double, 6, 6> ad = Eigen::Matrix<double, 6, 6>::Zero();
  ad.topLeftCorner<3, 3>() = R;
  ad.topRightCorner<3, 3>() = SkewSymmetric(T.translation) * R;
  ad.bottomRightCorner<3, 3>() = R;
  return ad;
}

Eigen::Matrix2d VirtualObservationSqrtInformation(const Rigid3d& cam_from_world,
                                                  const Line3d& line,
                                                  const Eigen::Vector3d& observed_normal,
                                                  const Eigen::Matrix3d& line_information,
                                                  double sigma_floor_rad) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(VirtualObservationInformation(
      cam_from_world, line, observed_normal, line_information, sigma_floor_rad));
  const Eigen::Vector2d root = eig.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  return eig.eigenvectors() * root.asDiagonal() * eig.eigenvectors().transpose();
}

}  // namespace lcv::slam
