#pragma once
// Point map -> line cloud: the publishing step (paper Sec. 3.4; Speciale et al. CVPR 2019).
//
// Each point landmark X becomes a line landmark with the same id:
// - direction d drawn uniformly on the unit sphere from the seeded RNG, independent of the scene;
// - information Omega_L = pinv((I - d d^T) Sigma_X (I - d d^T)) from the point's covariance;
// - anchor re-drawn as the point of the line closest to the map origin, a function of the line
//   alone, so it carries no information about where on the line X was;
// - descriptor kept; server-keyframe visibility = the keyframes that observed X.
// Client keyframes become server keyframes (pose and line ids only): every keypoint coordinate,
// descriptor list and observation is dropped. Restored points X' are dropped. Existing lines are
// kept (their restored points and client observations dropped).

#include <cstdint>

#include "slam/data/map.h"

namespace lcv::mapping {

struct LineCloudOptions {
  std::uint64_t seed = 0;
};

slam::Map ConvertToLineCloud(const slam::Map& point_map, const LineCloudOptions& options);

}  // namespace lcv::mapping
