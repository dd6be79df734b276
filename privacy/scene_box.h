#pragma once
// Where the hidden points of a line cloud are, estimated from the lines alone (as an attacker
// would): the box the line attacks index and search.
//
// Lines are infinite and their anchors are the points closest to the map origin (not local), so
// the box comes from where the lines are dense: (1) a generous cube around the origin whose
// half-size is a high quantile of the anchor distances (|anchor| = |X| sin(angle) <= |X|) and
// covers the given camera centres; (2) a coarse voxel count of lines in that cube; (3) for a
// sample of lines, the voxel of highest line density along each line, which lies on a surface
// of the scene; (4) the box of those points between per-axis quantiles, padded.

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "slam/geometry/line3.h"

namespace lcv::privacy {

struct SceneBoxOptions {
  int coarse_voxels_per_axis = 48;
  int max_samples = 20000;       // lines whose densest voxel is taken
  double trim_quantile = 0.01;   // per axis, the box spans [q, 1 - q] of the sampled peaks
  double padding_fraction = 0.1; // of the extent, added on each side
  int num_threads = 0;           // <= 0: all cores
};

// Empty box when there are no lines. Deterministic (the sample is a fixed stride).
Eigen::AlignedBox3d EstimateSceneBox(const std::vector<slam::Line3d>& lines,
                                     const std::vector<Eigen::Vector3d>& camera_centers,
                                     const SceneBoxOptions& options = {});

}  // namespace lcv::privacy
