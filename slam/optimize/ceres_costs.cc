#include "slam/optimize/ceres_costs.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include "slam/geometry/so3.h"
#include "slam/optimize/residuals.h"
#include "slam/util/error.h"

namespace lcv::slam::internal {
namespace {

// Writes a tangent Jacobian (rows x tangent, row-major into a rows x ambient block).
template <int kRows, int kTangent, int kAmbient>
void WriteLifted(const Eigen::Matrix<double, kRows, kTangent>& J_tangent, double* jacobian) {
  Eigen::Map<Eigen::Matrix<double, kRows, kAmbient, Eigen::RowMajor>> J(jacobian);
  J.template leftCols<kTangent>() = J_tangent;
  J.template rightCols<kAmbient - kTangent>().setZero();
}

}  // namespace

void PoseToParameters(const Rigid3d& pose, double* params) {
  const Eigen::Quaterniond q = pose.rotation.normalized();
  params[0] = q.x();
  params[1] = q.y();
  params[2] = q.z();
  params[3] = q.w();
  params[4] = pose.translation.x();
  params[5] = pose.translation.y();
  params[6] = pose.translation.z();
}

Rigid3d PoseFromParameters(const double* params) {
  Eigen::Quaterniond q(params[3], params[0], params[1], params[2]);
  q.normalize();
  return Rigid3d(q, Eigen::Vector3d(params[4], params[5], params[6]));
}

void LineToParameters(const Line3d& line, double* params) {
  Eigen::Map<Eigen::Vector3d>{params} = line.anchor;
  Eigen::Map<Eigen::Vector3d>{params + 3} = line.direction.normalized();
}

Line3d LineFromParameters(const double* params) {
  return Line3d(Eigen::Map<const Eigen::Vector3d>(params),
                Eigen::Map<const Eigen::Vector3d>(params + 3).normalized());
}

bool PoseManifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  const Vector6d d = Eigen::Map<const Vector6d>(delta);
  PoseToParameters(Rigid3d::Exp(d) * PoseFromParameters(x), x_plus_delta);
  return true;
}

bool PoseManifold::PlusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, kPoseSize, kPoseTangentSize, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.topRows<6>().setIdentity();
  return true;
}

bool PoseManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  const Rigid3d y_from_x = PoseFromParameters(y) * PoseFromParameters(x).Inverse();
  Eigen::Map<Vector6d>{y_minus_x} = y_from_x.Log();
  return true;
}

bool PoseManifold::MinusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, kPoseTangentSize, kPoseSize, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.leftCols<6>().setIdentity();
  return true;
}

bool LineManifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  const Eigen::Vector4d d = Eigen::Map<const Eigen::Vector4d>(delta);
  LineToParameters(RetractLine(LineFromParameters(x), d), x_plus_delta);
  return true;
}

bool LineManifold::PlusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, kLineSize, kLineTangentSize, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.topRows<4>().setIdentity();
  return true;
}

bool LineManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  const Line3d ly = LineFromParameters(y);
  const Line3d lx = LineFromParameters(x);
  const Matrix32d B = OrthonormalComplement(lx.direction);
  Eigen::Map<Eigen::Vector4d> out(y_minus_x);
  out.head<2>() = B.transpose() * (ly.anchor - lx.anchor);
  // The rotation about an axis orthogonal to d_x that takes d_x to d_y.
  const Eigen::Vector3d axis = lx.direction.cross(ly.direction);
  const double sin_angle = axis.norm();
  const double angle = std::atan2(sin_angle, lx.direction.dot(ly.direction));
  const Eigen::Vector3d omega =
      sin_angle > 1e-15 ? Eigen::Vector3d(axis * (angle / sin_angle)) : Eigen::Vector3d(axis);
  out.tail<2>() = B.transpose() * omega;
  return true;
}

bool LineManifold::MinusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, kLineTangentSize, kLineSize, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.leftCols<4>().setIdentity();
  return true;
}

bool ReprojectionCost::Evaluate(double const* const* parameters, double* residuals,
                                double** jacobians) const {
  const Rigid3d pose = PoseFromParameters(parameters[0]);
  const Eigen::Map<const Eigen::Vector3d> point(parameters[1]);
  Eigen::Vector2d r;
  Matrix26d J_pose;
  Matrix23d J_point;
  const bool want = jacobians != nullptr;
  if (!ReprojectionResidual(*camera_, pose, point, observed_px_, &r, want ? &J_pose : nullptr,
                            want ? &J_point : nullptr)) {
    return false;
  }
  Eigen::Map<Eigen::Vector2d>{residuals} = sqrt_information_ * r;
  if (jacobians) {
    if (jacobians[0]) {
      WriteLifted<2, 6, kPoseSize>(sqrt_information_ * J_pose, jacobians[0]);
    }
    if (jacobians[1]) {
      Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>>{jacobians[1]} =
          sqrt_information_ * J_point;
    }
  }
  return true;
}

LineObservationCost::LineObservationCost(const Camera* camera, const Eigen::Vector2d& observed_px,
                                         double information, const Line3d& line,
                                         const Eigen::Matrix3d& sqrt_line_information,
                                         double line_weight, const Rigid3d& cam_from_reference)
    : camera_(camera),
      observed_px_(observed_px),
      sqrt_information_(std::sqrt(information)),
      line_(line),
      weighted_sqrt_line_information_(std::sqrt(line_weight) * sqrt_line_information),
      cam_from_reference_(cam_from_reference),
      adjoint_(AdjointSE3(cam_from_reference)),
      has_offset_(cam_from_reference.translation.squaredNorm() > 0.0 ||
                  cam_from_reference.rotation.vec().squaredNorm() > 0.0) {}

bool LineObservationCost::Evaluate(double const* const* parameters, double* residuals,
                                   double** jacobians) const {
  const Rigid3d reference_from_world = PoseFromParameters(parameters[0]);
  const Rigid3d pose =
      has_offset_ ? cam_from_reference_ * reference_from_world : reference_from_world;
  const Eigen::Map<const Eigen::Vector3d> point(parameters[1]);
  Eigen::Vector2d r;
  Matrix26d J_pose;
  Matrix23d J_point;
  const bool want = jacobians != nullptr;
  if (!ReprojectionResidual(*camera_, pose, point, observed_px_, &r, want ? &J_pose : nullptr,
                            want ? &J_point : nullptr)) {
    return false;
  }
  Eigen::Vector3d r_line;
  Eigen::Matrix3d J_line_point;
  PointToLineResidual(point, line_, weighted_sqrt_line_information_, &r_line,
                      want ? &J_line_point : nullptr);
  Eigen::Map<Eigen::Matrix<double, 5, 1>> out(residuals);
  out.head<2>() = sqrt_information_ * r;
  out.tail<3>() = r_line;
  if (jacobians) {
    if (jacobians[0]) {
      Eigen::Matrix<double, 5, 6> J = Eigen::Matrix<double, 5, 6>::Zero();
      J.topRows<2>() = sqrt_information_ * J_pose;
      if (has_offset_) J.topRows<2>() = J.topRows<2>() * adjoint_;
      WriteLifted<5, 6, kPoseSize>(J, jacobians[0]);
    }
    if (jacobians[1]) {
      Eigen::Map<Eigen::Matrix<double, 5, 3, Eigen::RowMajor>> J(jacobians[1]);
      J.topRows<2>() = sqrt_information_ * J_point;
      J.bottomRows<3>() = J_line_point;
    }
  }
  return true;
}

bool ScaledOffsetLineCost::Evaluate(double const* const* parameters, double* residuals,
                                    double** jacobians) const {
  Rigid3d offset = cam_from_reference_;
  offset.translation *= parameters[2][0];
  // LineObservationCost reads only the first two blocks and writes only their Jacobians.
  const LineObservationCost at_scale(camera_, observed_px_, information_, line_,
                                     sqrt_line_information_, line_weight_, offset);
  if (!at_scale.Evaluate(parameters, residuals, jacobians)) return false;
  if (jacobians != nullptr && jacobians[2] != nullptr) {
    const Rigid3d cam_from_world = offset * PoseFromParameters(parameters[0]);
    const Eigen::Map<const Eigen::Vector3d> point(parameters[1]);
    Eigen::Matrix<double, 2, 3> J_px_p;
    if (!camera_->Project(cam_from_world * point, &J_px_p)) return false;
    const Eigen::Vector2d column =
        std::sqrt(information_) * J_px_p * cam_from_reference_.translation;
    jacobians[2][0] = column(0);
    jacobians[2][1] = column(1);
    jacobians[2][2] = jacobians[2][3] = jacobians[2][4] = 0.0;
  }
  return true;
}

FreeLineObservationCost::FreeLineObservationCost(const Camera* camera,
                                                 const Eigen::Vector2d& observed_px,
                                                 double information,
                                                 const Eigen::Matrix3d& sqrt_line_information,
                                                 double line_weight)
    : camera_(camera),
      observed_px_(observed_px),
      sqrt_information_(std::sqrt(information)),
      weighted_sqrt_line_information_(std::sqrt(line_weight) * sqrt_line_information) {}

bool FreeLineObservationCost::Evaluate(double const* const* parameters, double* residuals,
                                       double** jacobians) const {
  const Rigid3d pose = PoseFromParameters(parameters[0]);
  const Eigen::Map<const Eigen::Vector3d> point(parameters[1]);
  const Line3d line = LineFromParameters(parameters[2]);
  Eigen::Vector2d r;
  Matrix26d J_pose;
  Matrix23d J_point;
  const bool want = jacobians != nullptr;
  if (!ReprojectionResidual(*camera_, pose, point, observed_px_, &r, want ? &J_pose : nullptr,
                            want ? &J_point : nullptr)) {
    return false;
  }
  Eigen::Vector3d r_line;
  Eigen::Matrix3d J_line_point;
  Matrix34d J_line_line;
  PointToLineResidual(point, line, weighted_sqrt_line_information_, &r_line,
                      want ? &J_line_point : nullptr, want ? &J_line_line : nullptr);
  Eigen::Map<Eigen::Matrix<double, 5, 1>> out(residuals);
  out.head<2>() = sqrt_information_ * r;
  out.tail<3>() = r_line;
  if (jacobians) {
    if (jacobians[0]) {
      Eigen::Matrix<double, 5, 6> J = Eigen::Matrix<double, 5, 6>::Zero();
      J.topRows<2>() = sqrt_information_ * J_pose;
      WriteLifted<5, 6, kPoseSize>(J, jacobians[0]);
    }
    if (jacobians[1]) {
      Eigen::Map<Eigen::Matrix<double, 5, 3, Eigen::RowMajor>> J(jacobians[1]);
      J.topRows<2>() = sqrt_information_ * J_point;
      J.bottomRows<3>() = J_line_point;
    }
    if (jacobians[2]) {
      Eigen::Matrix<double, 5, 4> J = Eigen::Matrix<double, 5, 4>::Zero();
      J.bottomRows<3>() = J_line_line;
      WriteLifted<5, 4, kLineSize>(J, jacobians[2]);
    }
  }
  return true;
}

bool VirtualObservationCost::Evaluate(double const* const* parameters, double* residuals,
                                      double** jacobians) const {
  const Rigid3d pose = PoseFromParameters(parameters[0]);
  const Line3d line = LineFromParameters(parameters[1]);
  Eigen::Vector2d r;
  Matrix26d J_pose;
  Matrix24d J_line;
  const bool want = jacobians != nullptr;
  if (!VirtualObservationResidual(pose, line, observed_normal_, &r, want ? &J_pose : nullptr,
                                  want ? &J_line : nullptr)) {
    return false;
  }
  Eigen::Map<Eigen::Vector2d>{residuals} = sqrt_information_ * r;
  if (jacobians) {
    if (jacobians[0]) {
      WriteLifted<2, 6, kPoseSize>(sqrt_information_ * J_pose, jacobians[0]);
    }
    if (jacobians[1]) {
      WriteLifted<2, 4, kLineSize>(sqrt_information_ * J_line, jacobians[1]);
    }
  }
  return true;
}

bool CentreDistanceCost::Evaluate(double const* const* parameters, double* residuals,
                                  double** jacobians) const {
  const Rigid3d pose = PoseFromParameters(parameters[0]);
  const Eigen::Vector3d offset = pose.Center() - fixed_centre_;
  const double norm = offset.norm();
  if (!(norm > 0.0)) return false;
  residuals[0] = sqrt_weight_ * (norm - distance_);
  if (jacobians != nullptr && jacobians[0] != nullptr) {
    Eigen::Matrix<double, 1, 6> J = Eigen::Matrix<double, 1, 6>::Zero();
    J.leftCols<3>() = -sqrt_weight_ * (offset / norm).transpose() *
                      pose.rotation.toRotationMatrix().transpose();
    WriteLifted<1, 6, kPoseSize>(J, jacobians[0]);
  }
  return true;
}

SubBlockCost::SubBlockCost(std::unique_ptr<ceres::CostFunction> inner,
                           const std::vector<int>& outer_sizes, std::vector<Part> parts)
    : inner_(std::move(inner)), parts_(std::move(parts)) {
  const std::vector<int32_t>& inner_sizes = inner_->parameter_block_sizes();
  LCV_CHECK(inner_sizes.size() == parts_.size() &&
            static_cast<int>(parts_.size()) <= kMaxInnerBlocks)
      << "SubBlockCost: " << parts_.size() << " parts for " << inner_sizes.size() << " blocks";
  for (size_t j = 0; j < parts_.size(); ++j) {
    const Part& part = parts_[j];
    LCV_CHECK(part.outer >= 0 && part.outer < static_cast<int>(outer_sizes.size()) &&
              part.offset >= 0 && part.offset + inner_sizes[j] <= outer_sizes[part.outer] &&
              inner_->num_residuals() * inner_sizes[j] <= kMaxInnerJacobianSize)
        << "SubBlockCost: part " << j << " does not fit its outer block";
  }
  set_num_residuals(inner_->num_residuals());
  for (const int size : outer_sizes) mutable_parameter_block_sizes()->push_back(size);
}

bool SubBlockCost::Evaluate(double const* const* parameters, double* residuals,
                            double** jacobians) const {
  const std::vector<int32_t>& inner_sizes = inner_->parameter_block_sizes();
  const std::vector<int32_t>& outer_sizes = parameter_block_sizes();
  std::array<const double*, kMaxInnerBlocks> inner_parameters{};
  for (size_t j = 0; j < parts_.size(); ++j) {
    inner_parameters[j] = parameters[parts_[j].outer] + parts_[j].offset;
  }
  if (jacobians == nullptr) return inner_->Evaluate(inner_parameters.data(), residuals, nullptr);
  std::array<std::array<double, kMaxInnerJacobianSize>, kMaxInnerBlocks> storage;
  std::array<double*, kMaxInnerBlocks> inner_jacobians{};
  for (size_t j = 0; j < parts_.size(); ++j) {
    if (jacobians[parts_[j].outer] != nullptr) inner_jacobians[j] = storage[j].data();
  }
  if (!inner_->Evaluate(inner_parameters.data(), residuals, inner_jacobians.data())) {
    return false;
  }
  const int rows = num_residuals();
  for (size_t i = 0; i < outer_sizes.size(); ++i) {
    if (jacobians[i] != nullptr) std::fill_n(jacobians[i], rows * outer_sizes[i], 0.0);
  }
  for (size_t j = 0; j < parts_.size(); ++j) {
    if (inner_jacobians[j] == nullptr) continue;
    const int cols = inner_sizes[j];
    const int outer_cols = outer_sizes[parts_[j].outer];
    double* out = jacobians[parts_[j].outer] + parts_[j].offset;
    for (int r = 0; r < rows; ++r) {
      std::copy_n(inner_jacobians[j] + r * cols, cols, out + r * outer_cols);
    }
  }
  return true;
}

}  // namespace lcv::slam::internal
