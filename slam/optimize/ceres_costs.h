#pragma once
// Ceres building blocks shared by the Ceres problems of slam/optimize (local, global,
// rigid-stereo BA and the motion-only twin): parameter layouts, manifolds and analytic cost
// functions wrapping slam/optimize/residuals.h. Includes Ceres: include it from .cc files only.
//
// Parameter blocks
// - Pose, 7 doubles: [qx qy qz qw tx ty tz] of a cam_from_world Rigid3d. PoseManifold updates it
//   on the left, T <- Exp(delta) * T (slam/geometry/rigid3.h).
// - Line, 6 doubles: [anchor (3), direction (3)]. LineManifold updates it with RetractLine().
// - Points and restored points X': 3 doubles, Euclidean.
// - A free line with its X', 9 doubles: [line (6), X' (3)], LineWithPointManifold. Bundle
//   adjustment joins them so that the Schur complement can eliminate both (they share e_pL
//   terms, so as two blocks only one of them could be eliminated); SubBlockCost lets the cost
//   functions below, written for separate blocks, read their parts.
//
// Jacobian convention ("lifted" tangent Jacobians, as g2o-on-Ceres ports do): a cost function
// writes d(residual)/d(tangent) into the first tangent-size columns of the block's Jacobian and
// zeros in the rest, and the manifold's PlusJacobian is [I; 0]. Their product, the only thing
// Ceres' solvers use, is the exact tangent Jacobian; the ambient Jacobian alone is not the
// derivative wrt the stored numbers (so ceres::GradientChecker does not apply: the tests check
// the tangent Jacobians by central differences through the retraction instead).

#include <ceres/ceres.h>
#include <ceres/product_manifold.h>

#include <memory>
#include <vector>

#include <Eigen/Core>

#include "slam/camera/camera.h"
#include "slam/geometry/line3.h"
#include "slam/geometry/rigid3.h"

namespace lcv::slam::internal {

constexpr int kPoseSize = 7;
constexpr int kPoseTangentSize = 6;
constexpr int kLineSize = 6;
constexpr int kLineTangentSize = 4;
constexpr int kLineWithPointSize = kLineSize + 3;

void PoseToParameters(const Rigid3d& pose, double* params);
Rigid3d PoseFromParameters(const double* params);
void LineToParameters(const Line3d& line, double* params);
Line3d LineFromParameters(const double* params);

class PoseManifold : public ceres::Manifold {
 public:
  int AmbientSize() const override { return kPoseSize; }
  int TangentSize() const override { return kPoseTangentSize; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

class LineManifold : public ceres::Manifold {
 public:
  int AmbientSize() const override { return kLineSize; }
  int TangentSize() const override { return kLineTangentSize; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

// [line (6), X' (3)]: the line's retraction and a Euclidean X'. Tangent [line (4), X' (3)].
using LineWithPointManifold = ceres::ProductManifold<LineManifold, ceres::EuclideanManifold<3>>;

// A cost function evaluated on parts of larger parameter blocks: its parameter block j is the
// inner block size doubles of outer block parts[j].outer from parts[j].offset on (two inner
// blocks may lie in one outer block, e.g. a line and its X'). The inner function's Jacobian
// columns go to the same offsets; outer columns that no inner block covers are zero (with the
// lifted convention above this is the tangent Jacobian of a ProductManifold's block).
class SubBlockCost : public ceres::CostFunction {
 public:
  struct Part {
    int outer = 0;
    int offset = 0;
  };
  SubBlockCost(std::unique_ptr<ceres::CostFunction> inner, const std::vector<int>& outer_sizes,
               std::vector<Part> parts);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  static constexpr int kMaxInnerBlocks = 4;
  static constexpr int kMaxInnerJacobianSize = 64;  // residuals x inner block size
  std::unique_ptr<ceres::CostFunction> inner_;
  std::vector<Part> parts_;
};

// e_pP, whitened: sqrt(information) * (Project(T X) - x). Blocks: pose (7), point (3).
// An unprojectable point makes Evaluate return false (Ceres then rejects the step).
class ReprojectionCost : public ceres::SizedCostFunction<2, kPoseSize, 3> {
 public:
  ReprojectionCost(const Camera* camera, const Eigen::Vector2d& observed_px, double information)
      : camera_(camera), observed_px_(observed_px), sqrt_information_(std::sqrt(information)) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  const Camera* camera_;
  Eigen::Vector2d observed_px_;
  double sqrt_information_;
};

// e_pL with a fixed line, whitened: [sqrt(info_px) * (Project(T X') - x');
// sqrt(w_L) * S (I - d d^T) (X' - p_L)]. Blocks: pose (7), X' (3). With a fixed offset pose
// cam_from_reference (rigid-stereo BA), the pose block is reference_from_world and the camera
// pose is cam_from_reference * reference_from_world.
class LineObservationCost : public ceres::SizedCostFunction<5, kPoseSize, 3> {
 public:
  LineObservationCost(const Camera* camera, const Eigen::Vector2d& observed_px,
                      double information, const Line3d& line,
                      const Eigen::Matrix3d& sqrt_line_information, double line_weight,
                      const Rigid3d& cam_from_reference = Rigid3d());
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  const Camera* camera_;
  Eigen::Vector2d observed_px_;
  double sqrt_information_;
  Line3d line_;
  Eigen::Matrix3d weighted_sqrt_line_information_;
  Rigid3d cam_from_reference_;
  Eigen::Matrix<double, 6, 6> adjoint_;  // AdjointSE3(cam_from_reference)
  bool has_offset_;
};

// e_pL of a neighbour view of the rigid-stereo BA whose offset translation is multiplied by a
// free group scale g: cam_from_world = (R_offset, g t_offset) * reference_from_world. Blocks:
// reference pose (7), X' (3), g (1). Pose and X' columns are LineObservationCost's at the
// current g; the g column is sqrt(info_px) J_px_p t_offset (the line part does not depend on g).
class ScaledOffsetLineCost : public ceres::SizedCostFunction<5, kPoseSize, 3, 1> {
 public:
  ScaledOffsetLineCost(const Camera* camera, const Eigen::Vector2d& observed_px, double information,
                       const Line3d& line, const Eigen::Matrix3d& sqrt_line_information,
                       double line_weight, const Rigid3d& cam_from_reference)
      : camera_(camera),
        observed_px_(observed_px),
        information_(information),
        line_(line),
        sqrt_line_information_(sqrt_line_information),
        line_weight_(line_weight),
        cam_from_reference_(cam_from_reference) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  const Camera* camera_;
  Eigen::Vector2d observed_px_;
  double information_;
  Line3d line_;
  Eigen::Matrix3d sqrt_line_information_;
  double line_weight_;
  Rigid3d cam_from_reference_;
};

// e_pL with a free line (global BA). Blocks: pose (7), X' (3), line (6).
class FreeLineObservationCost : public ceres::SizedCostFunction<5, kPoseSize, 3, kLineSize> {
 public:
  FreeLineObservationCost(const Camera* camera, const Eigen::Vector2d& observed_px,
                          double information, const Eigen::Matrix3d& sqrt_line_information,
                          double line_weight);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  const Camera* camera_;
  Eigen::Vector2d observed_px_;
  double sqrt_information_;
  Eigen::Matrix3d weighted_sqrt_line_information_;
};

// e_vL in least-squares form (VirtualObservationResidual), whitened by the square root of
// Omega_vL (sqrt_information r; 1 / sigma_rad times the identity for the constant weight).
// Blocks: server pose (7), line (6).
class VirtualObservationCost : public ceres::SizedCostFunction<2, kPoseSize, kLineSize> {
 public:
  VirtualObservationCost(const Eigen::Vector3d& observed_normal, double sigma_rad)
      : observed_normal_(observed_normal),
        sqrt_information_(Eigen::Matrix2d::Identity() / sigma_rad) {}
  VirtualObservationCost(const Eigen::Vector3d& observed_normal,
                         const Eigen::Matrix2d& sqrt_information)
      : observed_normal_(observed_normal), sqrt_information_(sqrt_information) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Vector3d observed_normal_;
  Eigen::Matrix2d sqrt_information_;
};

// The monocular scale gauge term: sqrt_weight (|c - c_fixed| - distance), with c the centre of
// the (free) keyframe whose cam_from_world is the pose block (BundleScaleAnchor). Under the left
// perturbation the centre moves by -R^T v and not with the rotation part, so the tangent
// Jacobian is [-sqrt_weight u^T R^T, 0], u the unit direction from c_fixed to c. Evaluate
// returns false when the two centres coincide (the direction is undefined). Blocks: pose (7).
class CentreDistanceCost : public ceres::SizedCostFunction<1, kPoseSize> {
 public:
  CentreDistanceCost(const Eigen::Vector3d& fixed_centre, double distance, double sqrt_weight)
      : fixed_centre_(fixed_centre), distance_(distance), sqrt_weight_(sqrt_weight) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Vector3d fixed_centre_;
  double distance_;
  double sqrt_weight_;
};

}  // namespace lcv::slam::internal
