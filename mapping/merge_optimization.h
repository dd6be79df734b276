#pragma once
// Global optimization of a merged line cloud (issue 13; paper eq. 5 and 10 without images): all
// server keyframe poses and lines, constrained only by the virtual observations e_vL of each
// line by each server keyframe that sees it, with
// - the gauge fixed on the base map: its server keyframes and lines are held constant;
// - a robust loss (Huber on the whitened residual, huber_delta);
// - Omega_vL either propagated from Omega_L (VirtualObservationInformation in
//   slam/optimize/residuals.h, the default) or the constant 1 / virtual_sigma_rad^2.
//
// Observed copies. An upload's line merged into another line (a base line seen again, or a
// duplicate removed by the privacy rule) is a DIFFERENT line through the same point (its
// direction was drawn at random by its own session), so its virtual observations cannot be put
// on the kept line. It stays in the problem as a hidden, free "copy" (never published) that
// carries the upload's virtual observations and is tied to the kept line by the intersection
// residual (LineIntersectionResidual, whitened by the two lines' combined perpendicular sigma
// from their Omega_L): the upload's keyframes are held to the lines they saw, and those lines
// to the base lines they meet.
//
// Thread safety: pure function of its inputs; the map is modified in place.

#include <set>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "slam/data/map.h"
#include "slam/geometry/line3.h"

namespace lcv::mapping {

// n_v of line `line_id` by server keyframe `server_keyframe_id` (unit, camera frame).
struct VirtualObservationRecord {
  slam::Id server_keyframe_id = 0;
  slam::Id line_id = 0;
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  int copy = -1;  // >= 0: the observation is of ObservedLineCopy `copy`, not of the line itself
};

// An upload's own line merged into line `line_id` (see "Observed copies").
struct ObservedLineCopy {
  slam::Id line_id = 0;
  slam::Line3d line;  // base frame
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
};

struct MergeOptimizationOptions {
  bool propagate_information = true;  // Omega_vL from Omega_L; false: constant
  double virtual_sigma_rad = 2e-3;    // constant sigma, and the floor of the propagated one
  double huber_delta = 2.0;           // on the whitened residual (sigmas)
  int max_iterations = 30;
  int num_threads = 1;
  std::string Problem() const;
};

struct MergeOptimizationReport {
  bool success = false;
  int num_server_keyframes = 0;   // optimized
  int num_lines = 0;              // optimized
  int num_virtual_observations = 0;
  int num_copies = 0;  // observed line copies (hidden, see above)
  int num_iterations = 0;
  double cost_before = 0.0;  // Ceres cost (0.5 sum rho(|whitened r|^2))
  double cost_after = 0.0;
  double seconds = 0.0;
  std::string message;
};

// Largest perpendicular standard deviation of a line (map units) from pinv(Omega_L); infinity
// when Omega_L is zero.
double LinePerpendicularSigma(const Eigen::Matrix3d& information);

// The virtual observations of every (server keyframe, line) pair of the map from its current
// state (pairs whose line passes through the camera centre are left out).
std::vector<VirtualObservationRecord> VirtualObservationsOf(const slam::Map& map);

// Optimizes the server keyframes and lines of *map not listed as fixed. Records naming ids that
// are not in the map are ignored.
MergeOptimizationReport OptimizeLineCloud(const MergeOptimizationOptions& options,
                                          const std::vector<VirtualObservationRecord>& records,
                                          const std::vector<ObservedLineCopy>& copies,
                                          const std::set<slam::Id>& fixed_server_keyframes,
                                          const std::set<slam::Id>& fixed_lines, slam::Map* map);

}  // namespace lcv::mapping
