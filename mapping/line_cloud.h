#pragma once
// Point map -> line cloud: the publishing step (paper Sec. 3.4; Speciale et al. CVPR 2019).
//
// Each point landmark X becomes a line landmark with the same id (coincident points first become
// one point, see LineCloudOptions::coincident_distance):
// - direction d drawn uniformly on the unit sphere from the seeded RNG, independent of the scene;
// - information Omega_L = pinv((I - d d^T) Sigma_X (I - d d^T)) from the point's covariance;
// - anchor re-drawn as the point of the line closest to the map origin, a function of the line
//   alone, so it carries no information about where on the line X was;
// - descriptor kept; server-keyframe visibility = the keyframes that observed X.
// Client keyframes become server keyframes (pose and line ids only): every keypoint coordinate,
// descriptor list and observation is dropped. Restored points X' are dropped. Existing lines are
// kept (their restored points and client observations dropped; the keyframes that observed them
// join their visibility; their anchors are re-drawn by the same rule, which leaves an anchor
// already drawn by it unchanged). Visibility is made symmetric: a line lists exactly the server
// keyframes whose line_ids contain it, both sorted by id.
//
// Directions are drawn in point-id order from std::mt19937_64(seed): the same map and seed give
// the same line cloud. Never publish the same points twice with different seeds (or after
// re-drawing directions): two lines through one point intersect at it.
// Precondition: ids unique map-wide (as ValidateMap checks); checked, std::logic_error.

#include <cstdint>

#include "slam/data/map.h"

namespace lcv::mapping {

struct LineCloudOptions {
  std::uint64_t seed = 0;
  // Coincident points are merged before lines are drawn: two lines through one point cross
  // exactly there and reveal it (a COLMAP model of a street has ~5% of its points within a
  // millimetre of another). Points closer than coincident_distance (map units; < 0: 5e-5 x the
  // median distance of the points from their median, robust to far points; 0: off) become one line: the smallest id is kept,
  // at the points' mean, with the information-weighted covariance
  // (sum_i Sigma_i^-1)^-1, the union of their keyframes, the kept point's descriptor.
  double coincident_distance = -1.0;
};

struct LineCloudReport {
  int coincident_groups = 0;   // groups of coincident points found
  int points_merged_away = 0;  // points folded into another (no line of their own)
};

slam::Map ConvertToLineCloud(const slam::Map& point_map, const LineCloudOptions& options,
                             LineCloudReport* report = nullptr);

// The point map with coincident points merged as described in LineCloudOptions (distance > 0,
// map units); observations of merged points move to the kept one. For tests and the publisher.
slam::Map MergeCoincidentPoints(const slam::Map& point_map, double distance,
                                LineCloudReport* report = nullptr);

}  // namespace lcv::mapping
