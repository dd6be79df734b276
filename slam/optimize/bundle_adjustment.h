#pragma once
// Local BA (paper eq. 9) and global BA (eq. 10) with Ceres, on plain data: the caller copies the
// keyframes, points, lines and observations it wants optimized into a BundleProblem (indices,
// not ids, link them), calls SolveBundleAdjustment, and copies the results back. The engine's
// runtime map structures stay with their owner (slam/data), and the same problem serves the
// client's local mapping and the server's map merge.
//
//   local BA:  sum_i sum_j rho(e_pP(P_kc^i, X^j, x^ij)) + sum_i sum_k rho(e_pP(P_kc^i, X'^k, x'^ik)
//              + w_L ||X'^k - p_L^k||^2_{Omega_L})                         (lines fixed)
//   global BA: the same + sum_i' sum_l e_vL(P_ks^i', L^l, v^i'l)         (lines free)
//
// Gauge: the caller fixes keyframes (local BA: the border keyframes that see local points but
// are not local, and the first keyframe of the map; global BA: at least the first keyframe).
// When that leaves the monocular scale free (one fixed keyframe, nothing else that carries
// scale), the solver holds it (BundleOptions::hold_monocular_scale, BundleScaleAnchor).
// Lines are fixed unless BundleLine::fixed is false (global BA). Residuals: slam/optimize/
// residuals.h; poses and lines are updated on their tangent spaces (left pose perturbation,
// RetractLine()).
//
// Outliers (ORB-SLAM's LocalBundleAdjustment): optimize with Huber, then flag every observation
// whose chi^2 exceeds its threshold, and when options.refine_without_outliers is set, optimize
// again without them and without the kernel, and flag again. Flags are written to
// BundleObservation::outlier and are sticky: an observation flagged once (or passed in flagged)
// stays flagged. A point observation's chi^2 has 2 dof; a line observation's is the pixel part
// plus the line part w_L |S (I - d d^T)(X' - p_L)|^2 (4 dof). The line part is counted once per
// observation of X', as in the paper's sums (eq. 9, 10).
//
// Thread safety: the problem is owned by the caller and not shared during the call. Cameras are
// immutable and may be shared.

#include <functional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "slam/camera/camera.h"
#include "slam/geometry/line3.h"
#include "slam/geometry/rigid3.h"
#include "slam/util/ids.h"

namespace lcv::slam {

struct BundleKeyframe {  // a client keyframe P_kc
  Id id = kInvalidId;    // for the caller; not used by the solver
  Rigid3d cam_from_world;
  const Camera* camera = nullptr;  // not owned, must outlive the call
  bool fixed = false;
};

struct BundleServerKeyframe {  // a server keyframe P_ks (sees lines, no keypoints)
  Id id = kInvalidId;
  Rigid3d cam_from_world;
  bool fixed = false;
};

struct BundlePoint {  // a point landmark X
  Id id = kInvalidId;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // world, map units
  bool fixed = false;
};

struct BundleLine {  // a line L with its restored point X'
  Id id = kInvalidId;
  Line3d line;
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();  // Omega_L (rank 2)
  // X'. Optimized when the line has client observations; ignored otherwise.
  Eigen::Vector3d restored_point = Eigen::Vector3d::Zero();
  bool fixed = true;  // the line itself (p_L, d_L); false in global BA
};

// A keypoint of client keyframe `keyframe` (index into BundleProblem::keyframes) matched to
// point `landmark` (index into points), or, with on_line, to the X' of line `landmark`.
struct BundleObservation {
  int keyframe = -1;
  int landmark = -1;
  bool on_line = false;
  Eigen::Vector2d observed_px = Eigen::Vector2d::Zero();
  double information = 1.0;  // px^-2, 1 / sigma^2 of the keypoint's octave
  bool outlier = false;      // in: true excludes it; out: flagged (sticky, see above)
  double chi2 = 0.0;         // out, at the solution (infinity when not projectable)
};

// n_v: the virtual observation of line `line` by server keyframe `server_keyframe`, the unit
// normal (camera frame) of the plane through the camera centre and the initial line L0 of this
// problem (MakeVirtualObservations computes it from the state the problem was assembled with).
struct BundleVirtualObservation {
  int server_keyframe = -1;
  int line = -1;
  Eigen::Vector3d observed_normal = Eigen::Vector3d::UnitZ();
  // Square root of Omega_vL (2x2, on the residual of VirtualObservationResidual), e.g. from
  // VirtualObservationInformation (residuals.h). Zero: the constant 1 / virtual_sigma_rad.
  Eigen::Matrix2d sqrt_information = Eigen::Matrix2d::Zero();
};

// The monocular scale gauge of a bundle: the distance between the centres of a fixed keyframe
// and a free one, held at its initial value by a stiff term (CentreDistanceCost, sigma 1e-3 of
// the distance). See BundleOptions::hold_monocular_scale for when SolveBundleAdjustment sets it.
struct BundleScaleAnchor {
  int fixed_keyframe = -1;  // index into BundleProblem::keyframes
  int keyframe = -1;        // index into BundleProblem::keyframes; -1: no anchor
  double distance = 0.0;    // map units
};

struct BundleProblem {
  std::vector<BundleKeyframe> keyframes;
  std::vector<BundleServerKeyframe> server_keyframes;
  std::vector<BundlePoint> points;
  std::vector<BundleLine> lines;
  std::vector<BundleObservation> observations;
  std::vector<BundleVirtualObservation> virtual_observations;
  // Out (SolveBundleAdjustment): the anchor used, keyframe -1 when none.
  BundleScaleAnchor scale_anchor;

  // Empty when every index is in range, every keyframe has a camera and the numbers are
  // finite, else the first problem found ("observations[12]: keyframe 40 out of range").
  std::string Problem() const;
};

// One virtual observation for every (server keyframe, line) pair listed in pairs, from the
// current (initial) state of the problem. Pairs whose line passes through the camera centre
// are skipped.
void MakeVirtualObservations(const std::vector<std::pair<int, int>>& server_keyframe_line_pairs,
                             BundleProblem* problem);
// The same from other geometry than the problem's state: seen_from[i] stands for server keyframe
// i of the problem and seen_lines[j] for its line j (e.g. both as published, the paper's L0).
void MakeVirtualObservations(const std::vector<std::pair<int, int>>& server_keyframe_line_pairs,
                             const std::vector<Rigid3d>& seen_from,
                             const std::vector<Line3d>& seen_lines, BundleProblem* problem);

struct BundleOptions {
  int max_iterations = 10;             // Ceres iterations per optimization pass
  bool refine_without_outliers = true; // second pass without outliers and kernel
  int max_refine_iterations = 10;
  double point_chi2_threshold = 5.991;  // 2 dof
  double line_chi2_threshold = 9.488;   // 4 dof: pixel + line part of e_pL
  double line_weight = 1.0;             // w_L, see MotionOnlyBAOptions::line_weight
  // Omega_vL = 1 / virtual_sigma_rad^2: the angle (radians) by which a server keyframe's
  // view plane of a line may turn. 2e-3 rad is about one pixel at f = 500 px: the line cloud's
  // own reprojection accuracy, which is what the virtual observation stands in for.
  double virtual_sigma_rad = 2e-3;
  // Huber threshold on the whitened virtual residual (sigmas); <= 0: plain least squares.
  double virtual_huber_delta = 0.0;
  int num_threads = 1;
  double function_tolerance = 1e-6;
  // Polled after every Ceres iteration (from the solving thread); once it returns true the solve
  // stops with the best state it reached, skips the refine pass and classifies the outliers of
  // that state (BundleReport::stopped_early). ORB-SLAM's and stella_vslam's abort of local BA
  // when tracking queues a new keyframe: a live mapper that finishes every BA falls behind the
  // camera and refuses the next keyframes instead. Empty: never stops early.
  std::function<bool()> should_stop;
  // Monocular gauge: with exactly one fixed keyframe that observes anything, no fixed point and
  // no line-cloud term (lines, server keyframes), scaling every free keyframe and point about the
  // fixed keyframe's centre leaves every reprojection error unchanged: a flat direction of the
  // cost. Ceres then walks along it as its trust region grows, and the map's scale depends on
  // the iteration count (a 400-frame equirectangular loop ended at half its scale with 20
  // iterations instead of 10). When set, such a problem gets a BundleScaleAnchor from the fixed
  // keyframe to the free keyframe farthest from it, which removes only that direction.
  bool hold_monocular_scale = true;
  std::string Problem() const;
};

// The anchor hold_monocular_scale would add to this problem (keyframe -1: none needed).
BundleScaleAnchor ChooseScaleAnchor(const BundleProblem& problem);

struct BundleReport {
  bool success = false;  // Ceres returned a usable solution
  int num_iterations = 0;
  double initial_cost = 0.0;  // Ceres cost (0.5 sum of robustified squared whitened residuals)
  double final_cost = 0.0;
  int num_outliers = 0;       // observations flagged outlier at the end
  bool stopped_early = false;  // BundleOptions::should_stop ended it
  double time_ms = 0.0;
  std::string message;        // Ceres' termination message or the input problem
};

// Optimizes in place the non-fixed poses, points, restored points and lines of *problem.
// A problem with nothing to optimize returns success with zero iterations.
// Precondition: problem->Problem() is empty and options.Problem() is empty (LCV_CHECK).
BundleReport SolveBundleAdjustment(const BundleOptions& options, BundleProblem* problem);

}  // namespace lcv::slam
