#pragma once
// Global BA (paper eq. 10) over a whole slam::Map: the curator's `map optimize` and merge use
// it, the running SLAM builds its BundleProblem itself (slam/optimize/bundle_adjustment.h).
//
// Copies every client keyframe, point, line (with its restored point X' when it has one) and
// server keyframe of the map into a BundleProblem, adds the virtual observations v of every
// (server keyframe, line) pair listed in ServerKeyframe::line_ids from the map's current state
// (so the lines and server poses are held to the geometry they were published with), solves it,
// and writes the optimized state back. Observations are not removed: outliers are counted in
// the report only (the caller decides, e.g. `map optimize --drop-outliers`).
//
// Gauge: the num_fixed_keyframes client keyframes with the smallest ids are fixed (without
// client keyframes, that many server keyframes). Two by default: every term but the line term
// is invariant to a similarity, and the line term fixes the scale only weakly (its residuals are
// small at the optimum), so with one fixed keyframe the scale wanders (measured: a perturbed
// 6-keyframe map drifted by 4 m along that direction). Two fixed keyframes fix the scale by
// their distance; the map is in the server's metric frame already (registered by Sim(3)).
//
// Line information: the residual keeps the information matrix the line was published with
// (residuals.h, PointToLineResidual); when a line's direction turns, its written-back
// information is rotated with it (R Omega_L R^T, R the smallest rotation from the old to the new
// direction), so that the map invariant (direction in the null space) still holds.

#include <string>

#include "slam/data/map.h"
#include "slam/optimize/bundle_adjustment.h"

namespace lcv::slam {

struct MapBundleOptions {
  BundleOptions bundle;  // iterations, thresholds, w_L, sigma of the virtual observations
  // ORB pyramid scale factor: a keypoint of octave o has pixel information 1 / factor^(2 o).
  double pyramid_scale_factor = 1.2;
  bool optimize_lines = true;            // lines L free (eq. 10); false keeps them fixed
  bool optimize_server_keyframes = true; // P_ks free; false keeps them fixed
  int num_fixed_keyframes = 2;           // gauge, see above
  std::string Problem() const;
};

struct MapBundleReport {
  BundleReport bundle;
  int num_keyframes = 0;
  int num_server_keyframes = 0;
  int num_points = 0;
  int num_lines = 0;
  int num_observations = 0;
  int num_virtual_observations = 0;
  // Line observations skipped because the line has no restored point X' to attach them to.
  int num_skipped_observations = 0;
};

// Optimizes *map in place. Cameras are made from map->cameras. Precondition: the map satisfies
// the invariants of slam/data/map.h (mapping/io's reader checks them) and options.Problem() is
// empty (LCV_CHECK).
MapBundleReport GlobalBundleAdjustment(const MapBundleOptions& options, Map* map);

}  // namespace lcv::slam
