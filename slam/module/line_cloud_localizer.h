#pragma once
// Per-frame localization of a query image in a published line cloud: the p6L baseline of
// Speciale et al. (CVPR 2019), and the measure of what a privacy mitigation costs (docs/audit.md).
//
// 1. Matching: each query ORB descriptor against the line descriptors (lines without one are not
//    matchable), brute-force Hamming 2-NN with Lowe's ratio test and an absolute cap; when several
//    features pick one line, only the closest is kept (one-to-one).
// 2. Pose: RANSAC(p6L) on the bearings of the matched keypoints (Camera::Unproject) and their
//    lines, then Gauss-Newton on the inliers (slam/solve/p6l.h). The error is the bearing's angle
//    to the plane of camera centre and line: the threshold is max_error_px / focal (focal = fx, or
//    cols / 2 pi for an equirectangular camera), so every camera model uses one pixel setting.
//
// Frames: poses are cam_from_world in the line cloud's world frame and units. Nothing here knows a
// ground truth; `lcv localize` compares with one when the map is in the ground truth's frame.
//
// Thread safety: Localize is const and reentrant; the localizer holds a copy of the lines and
// descriptors, not a reference to the map.

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "slam/camera/camera.h"
#include "slam/data/map.h"
#include "slam/feature/keypoint.h"
#include "slam/solve/p6l.h"

namespace lcv::slam {

struct LineCloudLocalizerOptions {
  int max_hamming_distance = 64;  // of 256 bits
  double ratio = 0.8;             // best < ratio * second best
  double max_error_px = 3.0;      // RANSAC inlier threshold, converted to radians per camera
  int min_num_matches = 12;
  int min_num_inliers = 12;
  int max_ransac_trials = 2000;
  // Samples of the centre search with a rotation prior (Localize's rotation_prior): a 3x3
  // solve and the scoring of every match each.
  int max_rotation_prior_trials = 1000;
  // Inliers for the rotation prior's pose to be kept; with fewer, p6L searches. A wrong prior
  // (a camera that turned during an interruption) still finds a centre that a dozen lines fit:
  // kept at min_num_inliers, it hid the right p6L pose (fisheye s4 after 2.8 s of dropped
  // frames: the prior's pose had fewer than 30 inliers, p6L found 65 of 98).
  int min_rotation_prior_inliers = 30;
  std::uint64_t random_seed = 0;
  // Empty when usable, else what is wrong.
  std::string Problem() const;
};

struct LineCloudLocalization {
  bool success = false;
  Rigid3d cam_from_world;  // valid when success
  int num_features = 0;
  int num_matches = 0;  // after the ratio test and the one-to-one filter
  int num_inliers = 0;
  int num_trials = 0;
  // should_stop ended the work before RANSAC's own stopping rule did: a failure may then be a
  // pose that more samples would have found.
  bool stopped_early = false;
  // The pose came from the rotation prior's centre search (Localize), not from p6L, and the
  // samples that search drew (0 without a prior).
  bool from_rotation_prior = false;
  int num_rotation_prior_trials = 0;
  // (keypoint index, line id) of the inlier matches, and their bearings (query camera) and lines.
  std::vector<std::pair<int, Id>> inliers;
  std::vector<Eigen::Vector3d> inlier_bearings;
  std::vector<Line3d> inlier_lines;
  std::string failure;  // why not, when !success ("12 matches < 12", "RANSAC found no pose")
};

class LineCloudLocalizer {
 public:
  // camera: the query camera (outlives the localizer). Precondition: options.Problem() empty
  // (checked, std::logic_error).
  LineCloudLocalizer(const Map& line_cloud, const Camera& camera,
                     const LineCloudLocalizerOptions& options);

  // keypoints[i] has descriptors[i] (as OrbExtractor::Extract returns them).
  // max_ransac_trials > 0 replaces the options' cap for this call (a caller that can skip a
  // frame whose inlier ratio is low need not pay 2000 samples for it).
  // should_stop (empty: never asked) is asked after the matching and after every RANSAC sample;
  // true ends the search with the best pose so far (a deadline: a p6L sample costs 1.5-3 ms, and
  // a frame whose inlier ratio is low costs max_ransac_trials of them).
  // seed_offset is added to the options' random_seed (repeated calls that should not draw the
  // same samples, e.g. a check retried on the next frames).
  // rotation_prior (cam_from_world rotation): first RANSAC over the camera centre with that
  // rotation held (slam/solve/p3l_known_rotation.h), then Gauss-Newton on all six degrees of
  // freedom of its inliers; p6L runs only when that finds no pose of
  // max(min_num_inliers, min_rotation_prior_inliers).
  LineCloudLocalization Localize(
      const std::vector<Keypoint>& keypoints, const std::vector<OrbDescriptor>& descriptors,
      int max_ransac_trials = 0, const std::function<bool()>& should_stop = {},
      std::uint64_t seed_offset = 0,
      const std::optional<Eigen::Quaterniond>& rotation_prior = std::nullopt) const;

  int num_matchable_lines() const { return static_cast<int>(line_ids_.size()); }
  double max_error_rad() const { return max_error_rad_; }

 private:
  const Camera& camera_;
  LineCloudLocalizerOptions options_;
  double max_error_rad_ = 0.0;
  std::vector<Id> line_ids_;
  std::vector<Line3d> lines_;
  std::vector<OrbDescriptor> descriptors_;
};

}  // namespace lcv::slam
