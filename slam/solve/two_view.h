#pragma once
// Two-view geometry for monocular initialization (ORB-SLAM's Initializer, on bearings).
//
// From bearing correspondences x1[i] <-> x2[i] between a reference frame and the current frame,
// estimates in parallel an essential matrix (always) and a homography (when allowed: perspective
// cameras only, as it works on normalized coordinates), chooses one by ORB-SLAM's score ratio
// R_H = S_H / (S_H + S_E) (> homography_ratio picks H), decomposes it, and keeps the motion
// that triangulates the most points with positive depth, small reprojection angle and enough
// parallax. The result is cam2_from_cam1 with |t| = 1 (monocular scale is arbitrary; the
// initializer normalizes it after its first BA) and points in the frame of camera 1.
//
// Fails (success = false, reason set) when there are too few inliers, too few triangulated
// points, too little parallax (fewer than parallax_rank points above parallax_threshold_deg), or when two motions explain the data almost equally well
// (ambiguous: wait for more motion). Deterministic for a given seed.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "slam/geometry/rigid3.h"
#include "slam/solve/ransac.h"

namespace lcv::slam {

struct TwoViewOptions {
  // Inlier threshold, radians (~ px / focal_px). Also the reprojection check of triangulation.
  double max_angular_error_rad = 0.003;
  // Parallax below which a point is not triangulated (degrees).
  double min_point_parallax_deg = 0.5;
  // The accepted motion needs at least parallax_rank points (well-reprojecting, in front of both
  // cameras) with a parallax of parallax_threshold_deg or more: the parallax_rank-th largest
  // parallax must reach the threshold (ORB-SLAM's and stella_vslam's gate, both with rank 50
  // and 1 degree). A median gate (used before) waits far longer under forward or turning
  // motion, where the points that gain parallax (near, at the image border) are the first to
  // leave the view while distant ones stay: on KITTI 00's turn (frames 100-130, 0.4 m and 2-3.5
  // deg per frame) the median stayed at 0.4-0.9 deg for 14 frames while hundreds of points had
  // more than 1 deg (docs/slam.md, "Initialization").
  double parallax_threshold_deg = 1.0;
  int parallax_rank = 50;
  int min_num_triangulated = 50;
  // Fraction of the inliers that the chosen motion must triangulate.
  double min_triangulated_ratio = 0.9;
  // The second-best motion must triangulate fewer than this fraction of the best one's points
  // (ORB-SLAM: 0.7 for the essential matrix, 0.75 for the homography, whose two-fold planar
  // ambiguity often keeps many points in front for the twin solution).
  double max_ambiguity_ratio = 0.7;
  double max_homography_ambiguity_ratio = 0.75;
  // Try a homography too (perspective cameras only: needs bearings with z > 0).
  bool use_homography = true;
  double homography_ratio = 0.45;  // ORB-SLAM: R_H > 0.45 -> homography
  // Cap on RANSAC samples per model (adaptive: clean data stops far earlier). Eight-point
  // samples at a 50% inlier ratio need ~1300 trials for 99.9% confidence.
  int max_ransac_trials = 2000;
  // The homography's 4-point samples need far fewer (~110 at 50% inliers); on a non-planar
  // scene its RANSAC never stops early, so its own cap keeps an attempt cheap.
  int max_homography_trials = 300;
  std::uint64_t random_seed = 0;
  std::optional<std::string> Problem() const;
  void Check() const;
};

struct TwoViewGeometry {
  enum class Model { kNone, kEssential, kHomography };
  bool success = false;
  std::string reason;  // why it failed, for logs ("too few triangulated points: 31 < 50")
  Model model = Model::kNone;
  Rigid3d cam2_from_cam1;  // |translation| = 1 on success
  int num_inliers = 0;
  int num_triangulated = 0;
  double median_parallax_deg = 0.0;
  double ranked_parallax_deg = 0.0;  // the parallax_rank-th largest parallax (see the options)
  std::vector<char> inlier_mask;                   // per correspondence: fits the model
  std::vector<char> triangulated;                  // per correspondence: point valid
  std::vector<Eigen::Vector3d> points_in_cam1;     // per correspondence; valid where triangulated
};

// bearings1/bearings2: unit bearings, same length. Precondition: options.Check() passes.
TwoViewGeometry EstimateTwoViewGeometry(const std::vector<Eigen::Vector3d>& bearings1,
                                        const std::vector<Eigen::Vector3d>& bearings2,
                                        const TwoViewOptions& options);

}  // namespace lcv::slam
