#pragma once
// The paper's construction of a prebuilt map for its benchmarks (Sec. 4.1, KITTI): "(I) perform
// a standard Visual SLAM to estimate initial camera poses and 3D points, (II) replace the
// estimated camera poses with the ground truth, (III) perform a bundle adjustment to [...]
// refine the positions of the 3D points." A Sim(3) alignment alone (privacy/map_alignment.h)
// keeps the SLAM map's own errors: scale drift along a street compresses one end of the map by
// a few percent, and a client localized in it inherits that error. On the ground-truth poses
// the map's points are where the scene is, up to their triangulation noise.
//
// Ground truth has errors of its own, which is why the paper's step (III) is a BA. Here the
// keyframes take the ground truth's centres and orientations, optionally turned by the camera's
// mean rotation against the ground truth's camera frame (estimate_camera_rotation: the chordal
// mean of R_map R_gt^T over the aligned keyframes, a camera-mount calibration for a ground truth
// that belongs to another body frame; off by default because on an exact ground truth it would
// only turn the keyframes by the SLAM map's mean orientation error). Then a structure-only BA
// moves every point to minimize its reprojection errors (Huber, then again without the
// observations flagged as outliers, slam/optimize/bundle_adjustment.h). A second BA with the
// poses free too (refine_poses, off by default) holds the first two keyframes for gauge and
// scale. Observations still flagged at the end are removed, and so are points left with fewer
// than two.
//
// Measured on KITTI 00 (bench/bench_lcvslam.sh's server map, odd frames): its ground truth does
// not fit the images as well as the synthetic one. The map's points reproject 15 px off on it;
// after the structure-only BA 2.0 px of RMS remain and 1 observation in 8 is an outlier (the
// synthetic maps: 1.0 px, almost none). The estimated camera rotation is 0.54 degrees and
// leaves 13.7 px / 1.97 px; the second BA drifts in scale (keyframe centres up to 1.3 m off the
// ground truth after 117 m). A client localized in either KITTI map is worse than in the
// Sim(3)-aligned SLAM map (docs/benchmarks-lcvslam.md "Server maps on the ground truth").
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
  // Estimate and apply the camera's constant rotation against the ground truth's camera frame.
  bool estimate_camera_rotation = false;
  bool refine_poses = false;          // the second BA (poses too); false: structure only
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
  // Largest move of a keyframe centre away from its ground-truth pose by the second BA.
  double max_pose_correction_m = 0.0;
  // The camera's rotation against the ground truth's camera frame that was applied, degrees.
  double camera_rotation_offset_deg = 0.0;
};

// Throws lcv::InputError (source_name: problem) for a map with lines or server keyframes, a map
// whose keyframes match no ground-truth pose, or a BA that fails.
slam::Map PutMapOnGroundTruthPoses(const slam::Map& aligned_map,
                                   const mapping::Trajectory& ground_truth,
                                   const GroundTruthPosesOptions& options,
                                   const std::string& source_name,
                                   GroundTruthPosesReport* report = nullptr);

}  // namespace lcv::privacy
