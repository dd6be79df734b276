#pragma once
// The paper's construction of a prebuilt map for its benchmarks (Sec. 4.1, KITTI): "(I) perform
// a standard Visual SLAM to estimate initial camera poses and 3D points, (II) replace the
// estimated camera poses with the ground truth, (III) perform a bundle adjustment to [...]
// refine the positions of the 3D points." A Sim(3) alignment alone (privacy/map_alignment.h)
// keeps the SLAM map's own errors: scale drift along a street compresses one end of the map by
// a few percent, and a client localized in it inherits that error. On the ground-truth poses
// the map's points are where the scene is, up to their triangulation noise.
//
// Step (III) here is a structure-only BA: every keyframe stays at its ground-truth pose (the
// synthetic ground truth is exact and KITTI's is accurate to centimetres, so there are no pose
// errors for it to correct), every point moves to minimize its reprojection errors (Huber,
// then again without the observations flagged as outliers, slam/optimize/bundle_adjustment.h).
// Observations still flagged afterwards are removed, and so are points left with fewer than two.
// Point covariances (Sigma_X) are kept as they came: the SLAM estimate's, moved by the alignment.
//
// Input: a point map already moved into the ground truth's frame (TransformMap with
// AlignMapToGroundTruth), so that its points start near their refined place. Keyframes without a
// ground-truth pose within the time tolerance keep their aligned pose (also fixed). Maps with
// lines or server keyframes (line clouds) are refused: convert the point map afterwards.
//
// Thread safety: pure function of its arguments.
#include <string>

#include "mapping/io/trajectory.h"
#include "slam/data/map.h"

namespace lcv::privacy {

struct GroundTruthPosesOptions {
  double max_time_difference = 0.02;  // seconds, the keyframe <-> ground-truth association
  int max_iterations = 20;            // per BA pass
};

struct GroundTruthPosesReport {
  int keyframes_on_ground_truth = 0;  // poses replaced
  int keyframes_kept = 0;             // no ground truth within the tolerance: aligned pose kept
  int points_in = 0;
  int points_out = 0;
  int observations_removed = 0;       // flagged as outliers by the BA
  // Root mean square reprojection error (px) of the observations kept, on the ground-truth poses
  // before the BA (points as aligned) and after it.
  double rms_px_before = 0.0;
  double rms_px_after = 0.0;
};

// Throws lcv::InputError (source_name: problem) for a map with lines or server keyframes, a map
// whose keyframes match no ground-truth pose, or a BA that fails.
slam::Map PutMapOnGroundTruthPoses(const slam::Map& aligned_map,
                                   const mapping::Trajectory& ground_truth,
                                   const GroundTruthPosesOptions& options,
                                   const std::string& source_name,
                                   GroundTruthPosesReport* report = nullptr);

}  // namespace lcv::privacy
