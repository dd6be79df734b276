#pragma once
// Absolute and relative pose errors (APE / RPE) of an estimated trajectory against ground
// truth, computed exactly as evo (github.com/MichaelGrupp/evo, metrics.py, sync.py) does:
//
// 1. Association (evo sync.associate_trajectories): for every pose of the SHORTER trajectory,
//    the pose of the longer one with the nearest timestamp (first one on ties) is its match
//    when |t_a - t_b| <= max_time_difference_s. A pose of the longer trajectory may be matched
//    more than once, as in evo.
// 2. Alignment of the estimate onto the ground truth (evo --align / --correct_scale): Umeyama
//    (slam/solve/umeyama.h) on the matched camera centres, SE(3) or Sim(3), or none (or, not
//    evo's, the rotation from the cameras' orientations: align_with_orientations). The
//    estimate's camera-to-world poses P_i become S * P_i (rotation R_S R_i, centre
//    s R_S c_i + t_S).
// 3. Errors, with camera-to-world poses Q_i (ground truth) and P_i (aligned estimate):
//    APE: E_i = Q_i^-1 P_i.
//    RPE: for pairs (i, j = i + delta), E = (Q_i^-1 Q_j)^-1 (P_i^-1 P_j); pairs are
//         (0, d), (d, 2d), ... by default, or every (i, i + d) with all_pairs (evo --all_pairs).
//    translation error |trans(E)| (metres when the ground truth is metric; for APE this is the
//    distance between the camera centres), rotation error angle(E) in degrees.
// 4. Statistics as evo's: rmse, mean, median, std (population), min, max, sse.

#include <optional>
#include <string>
#include <vector>

#include "mapping/io/trajectory.h"
#include "slam/geometry/sim3.h"

namespace lcv::mapping {

enum class TrajectoryAlignment { kNone, kSE3, kSim3 };

// "none", "se3", "sim3"; empty for anything else.
std::optional<TrajectoryAlignment> ParseTrajectoryAlignment(const std::string& name);
const char* TrajectoryAlignmentName(TrajectoryAlignment alignment);

// Matched pose indices: gt.poses[gt_indices[k]] <-> est.poses[est_indices[k]], in the order of
// the shorter trajectory.
struct TrajectoryAssociation {
  std::vector<int> gt_indices;
  std::vector<int> est_indices;
};

// Step 1. Precondition: both trajectories' timestamps increase (the readers guarantee it).
TrajectoryAssociation AssociateByTimestamp(const Trajectory& gt, const Trajectory& est,
                                           double max_time_difference_s);

struct ErrorStatistics {
  int count = 0;
  double rmse = 0, mean = 0, median = 0, std = 0, min = 0, max = 0, sse = 0;
};
// Statistics of values (all zero for an empty vector).
ErrorStatistics ComputeErrorStatistics(std::vector<double> values);

struct TrajectoryErrorOptions {
  double max_time_difference_s = 0.01;
  TrajectoryAlignment alignment = TrajectoryAlignment::kNone;
  // With an alignment, its rotation from the cameras' orientations instead of the centres'
  // point sets (slam::AlignPoseSets: the chordal mean of the matched cameras' relative
  // rotations; scale and translation the least-squares fit of the centres given it). Not
  // evo's: evo fits the centres alone, and the centres of a nearly straight path (a street)
  // leave the rotation about it to noise. Measured on a 60-frame street map whose own
  // keyframes were 0.12 degrees (median) off the truth: the centres' fit turned it by 1.7
  // degrees, the orientations' did not. The ground truth must be of the estimate's camera frame
  // (a body or IMU frame's fixed rotation would enter the alignment).
  bool align_with_orientations = false;
  int rpe_delta = 1;            // frames (matched poses), RPE only; >= 1
  bool rpe_all_pairs = false;   // RPE only
};

struct TrajectoryErrorReport {
  // Empty on success, else why no errors could be computed ("no poses associated within
  // 0.01 s", "alignment degenerate: fewer than 3 matched poses or collinear centres").
  std::optional<std::string> problem;
  int matched = 0;  // associated poses
  // The matched ground-truth centres' second principal spread over their first (standard
  // deviations; 0 with fewer than two poses). Near 0 for a straight path: there the centres'
  // alignment cannot pin the rotation about it (see align_with_orientations).
  double centre_spread_ratio = 0.0;
  // The applied alignment, gt_world_from_est_world (identity for kNone).
  slam::Sim3d gt_from_est;
  // One entry per associated pose (APE) or per pair (RPE), in order: timestamp of the (first)
  // ground-truth pose, translation error (gt units), rotation error (degrees).
  std::vector<double> timestamps;
  std::vector<double> translation_errors;
  std::vector<double> rotation_errors_deg;
  // Camera centres of the same entries (for an RPE pair, its first pose), in the ground
  // truth's frame: the ground truth's and the aligned estimate's (for plots).
  std::vector<Eigen::Vector3d> gt_centres;
  std::vector<Eigen::Vector3d> est_centres;
  ErrorStatistics translation;
  ErrorStatistics rotation_deg;
};

// Steps 1-4. Precondition: options.rpe_delta >= 1, options.max_time_difference_s >= 0.
TrajectoryErrorReport ComputeApe(const Trajectory& gt, const Trajectory& est,
                                 const TrajectoryErrorOptions& options);
TrajectoryErrorReport ComputeRpe(const Trajectory& gt, const Trajectory& est,
                                 const TrajectoryErrorOptions& options);

}  // namespace lcv::mapping
