#pragma once
// Motion-only BA (paper eq. 6): the pose of the current frame P_c and the restored points X' of
// matched lines, with map points X and lines L fixed:
//
//   P_c*, X'* = argmin  sum_j rho(e_pP(P_c, X_j, x_j))
//                     + sum_k rho(e_pP(P_c, X'_k, x'_k) + w_L ||X'_k - p_L^k||^2_{Omega_L})
//
// Hand-written Levenberg-Marquardt on fixed-size Eigen (the per-frame budget does not fit Ceres:
// ARCHITECTURE.md measured 17-35 ms vs 0.43 ms). Each X'_k is a 3-vector coupled only to the
// pose, so the normal equations are reduced to 6x6 by eliminating every X'_k (Schur complement,
// one 3x3 block per line term) and back-substituted.
//
// Outliers are rejected in rounds as ORB-SLAM's PoseOptimization: num_rounds rounds of
// iterations_per_round LM iterations over the current inliers, then every term (also the
// rejected ones) is reclassified by its chi^2 at the new pose; the Huber kernel is used in the
// first robust_rounds rounds only.
//
// A point term's chi^2 is r^T r * information (2 dof, threshold 5.991). A line term's chi^2 is
// the pixel part plus the line part w_L r_L^T r_L (4 dof, threshold 9.488); for a rejected line
// term X' is first re-fitted to the pose with the pixel and line terms (3 GN steps).
//
// Thread safety: a MotionOnlyBA object holds scratch buffers; use one per thread.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "slam/camera/camera.h"
#include "slam/geometry/line3.h"
#include "slam/geometry/rigid3.h"

namespace lcv::slam {

// A 2D-3D match with a map point X (e_pP).
struct MotionOnlyPointTerm {
  Eigen::Vector3d p_in_world = Eigen::Vector3d::Zero();  // X, fixed
  Eigen::Vector2d observed_px = Eigen::Vector2d::Zero();  // x
  // Pixel information 1 / sigma^2 (px^-2); ORB-SLAM: 1 / scale_factor^(2 * octave).
  double information = 1.0;
  // In: false excludes the term from the start (still reclassified after each round).
  // Out: the final classification.
  bool inlier = true;
  double chi2 = 0.0;  // out: at the final pose (infinity when not projectable)
};

// A 2D point x' matched to a line L of a line cloud, through the restored point X' (e_pL).
struct MotionOnlyLineTerm {
  Line3d line;  // L = {p_L, d_L}, fixed
  // sqrt(Omega_L) (SqrtInformation() of LineLandmark::information), map units^-1.
  Eigen::Matrix3d sqrt_information = Eigen::Matrix3d::Zero();
  Eigen::Vector2d observed_px = Eigen::Vector2d::Zero();  // x'
  double information = 1.0;  // pixel information, px^-2
  // In: initial X' (e.g. the midpoint between the ray of x' and L); out: optimized X'.
  Eigen::Vector3d restored_point = Eigen::Vector3d::Zero();
  bool inlier = true;  // in/out as MotionOnlyPointTerm::inlier
  double chi2 = 0.0;   // out
};

struct MotionOnlyBAOptions {
  int num_rounds = 4;
  int iterations_per_round = 10;
  int robust_rounds = 2;  // Huber kernel in rounds [0, robust_rounds)
  double point_chi2_threshold = 5.991;  // 2 dof, 95%
  double line_chi2_threshold = 9.488;   // 4 dof, 95%
  // w_L, the weight of the line term relative to the pixel term. Omega_L and the pixel
  // information are both inverse covariances, so 1 makes the sum a chi^2; larger values pull X'
  // onto the line harder.
  double line_weight = 1.0;
  double initial_lambda = 1e-4;  // LM damping, relative to the Hessian's diagonal
  // Stop a round early once the pose step is below this (|delta|, radians and map units) or an
  // accepted step lowered the cost by less than function_tolerance times the cost. 1e-6 is
  // Ceres' default: near the minimum Gauss-Newton's next step gains a fraction of that, and
  // 1e-9 spent a third of the iterations confirming a pose that moved by micrometres (tracking
  // on the equirectangular overlap pairs: 14.4 -> 9.4 iterations per solve, the trajectories
  // the same to 3e-5 m; docs/benchmarks-lcvslam.md "Motion-only BA's stopping rule").
  double min_step_norm = 1e-9;
  double function_tolerance = 1e-6;
  // Empty when valid, else what is wrong.
  std::string Problem() const;
};

struct MotionOnlyBAReport {
  // False when no term was ever usable or the 6x6 system was singular throughout (too few
  // inliers to fix the pose): the pose is then left at its initial value.
  bool success = false;
  int num_iterations = 0;      // LM iterations over all rounds
  int num_point_inliers = 0;
  int num_line_inliers = 0;
  double initial_cost = 0.0;   // 0.5 * sum chi^2 over the initial inliers, at the initial pose
  double final_cost = 0.0;     // 0.5 * sum chi^2 over the final inliers, at the final pose
};

// The paper's initial X' (Sec. 3.4): the midpoint between the viewing ray of x' (unit bearing in
// the camera frame, from Camera::Unproject) and the line L at their closest approach. When the
// ray and the line are parallel, or the closest point lies behind the camera, the point of L
// closest to the camera centre is returned instead (the midpoint would be meaningless).
Eigen::Vector3d InitialRestoredPoint(const Rigid3d& cam_from_world,
                                     const Eigen::Vector3d& bearing_in_cam, const Line3d& line);

class MotionOnlyBA {
 public:
  explicit MotionOnlyBA(const MotionOnlyBAOptions& options = MotionOnlyBAOptions());

  // Refines *cam_from_world in place from the terms; writes each term's inlier flag and chi2,
  // and each line term's restored_point. camera must outlive the call. No allocation once the
  // buffers have grown to the largest problem seen.
  MotionOnlyBAReport Solve(const Camera& camera, Rigid3d* cam_from_world,
                           std::vector<MotionOnlyPointTerm>* points,
                           std::vector<MotionOnlyLineTerm>* lines);

  const MotionOnlyBAOptions& options() const { return options_; }

 private:
  // One term's residual and Jacobians at a linearization point. They are kept so that the
  // linearization an LM step was accepted at also serves the round's reclassification and the
  // next round's normal equations (those terms are at the same pose): the projections, most of
  // a solve's cost, are computed once per pose instead of up to three times.
  struct PointTermEvaluation {
    Eigen::Vector2d r;
    Eigen::Matrix<double, 2, 6> J_pose;
  };
  struct LineTermEvaluation {
    Eigen::Vector2d r;
    Eigen::Matrix<double, 2, 6> J_pose;
    Eigen::Matrix<double, 2, 3> J_point;
  };
  // The normal equations of one linearization, X' blocks kept apart for the Schur complement.
  struct LineBlock {
    Eigen::Matrix<double, 6, 3> H_pose_point;
    Eigen::Matrix3d H_point_point;
    Eigen::Vector3d g_point;
  };
  struct Linearization {
    Eigen::Matrix<double, 6, 6> H_pose_pose;
    Eigen::Matrix<double, 6, 1> g_pose;
    double cost = 0.0;  // 0.5 * sum rho(chi^2) over the active terms
    std::vector<LineBlock> lines;
    // Valid for the terms that were active (inlier) when evaluated, and for the terms the
    // reclassification evaluated since.
    std::vector<PointTermEvaluation> point_terms;
    std::vector<LineTermEvaluation> line_terms;
  };
  // Evaluates every active term at (pose, points) into out->point_terms / line_terms; false
  // when an active term cannot be projected.
  bool Evaluate(const Camera& camera, const Rigid3d& cam_from_world,
                const std::vector<MotionOnlyPointTerm>& points,
                const std::vector<MotionOnlyLineTerm>& lines,
                const std::vector<Eigen::Vector3d>& restored_points,
                Linearization* out) const;
  // The normal equations and cost of the active terms from their evaluations.
  void Accumulate(const std::vector<MotionOnlyPointTerm>& points,
                  const std::vector<MotionOnlyLineTerm>& lines,
                  const std::vector<Eigen::Vector3d>& restored_points, bool robust,
                  Linearization* out) const;
  // LM over the active terms from current_ (evaluated at *cam_from_world by the caller); returns
  // false when the reduced system was singular. current_ holds the evaluations at the returned
  // pose.
  bool RunLevenbergMarquardt(const Camera& camera, bool robust, Rigid3d* cam_from_world,
                             const std::vector<MotionOnlyPointTerm>& points,
                             std::vector<MotionOnlyLineTerm>* lines, int* num_iterations);

  MotionOnlyBAOptions options_;
  Linearization current_;
  Linearization candidate_;
  std::vector<Eigen::Matrix3d> line_jacobians_;  // S (I - d d^T) per line term
  std::vector<Eigen::Vector3d> current_points_;
  std::vector<Eigen::Vector3d> candidate_points_;
};

// The same problem solved by Ceres (the twin of MotionOnlyBA for tests and benchmarks; too slow
// per frame): same residuals, Huber kernel and rounds, Schur elimination of X'.
MotionOnlyBAReport SolveMotionOnlyBACeres(const MotionOnlyBAOptions& options,
                                          const Camera& camera, Rigid3d* cam_from_world,
                                          std::vector<MotionOnlyPointTerm>* points,
                                          std::vector<MotionOnlyLineTerm>* lines);

namespace internal {

// chi^2 of a term at cam_from_world as defined above; infinity when not projectable.
double PointTermChi2(const Camera& camera, const Rigid3d& cam_from_world,
                     const MotionOnlyPointTerm& term);
// line_jacobian = S (I - d d^T) of the term's line (precomputed by the caller).
double LineTermChi2(const Camera& camera, const Rigid3d& cam_from_world,
                    const MotionOnlyLineTerm& term, const Eigen::Matrix3d& line_jacobian,
                    double line_weight);
// Re-fits term->restored_point to the pose (3 Gauss-Newton steps on the term alone).
void RefitRestoredPoint(const Camera& camera, const Rigid3d& cam_from_world,
                        const Eigen::Matrix3d& line_jacobian, double line_weight,
                        MotionOnlyLineTerm* term);

}  // namespace internal
}  // namespace lcv::slam
