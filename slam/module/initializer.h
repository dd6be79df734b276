#pragma once
// Monocular map initialization from two frames (ORB-SLAM / stella_vslam's initializer, on
// bearings): keypoints of a reference frame are followed by area matching; once enough matches
// exist, EstimateTwoViewGeometry (slam/solve/two_view.h) estimates the relative pose (essential
// matrix, and homography on perspective images, for planar scenes) and triangulates the matches
// with parallax and reprojection checks; the result is accepted only with enough points.
// The caller builds the map from the result, runs the initial BA and normalizes the scale.
//
// Not thread-safe; owned by the tracking thread. Deterministic for a given seed.

#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "slam/data/frame.h"
#include "slam/geometry/rigid3.h"
#include "slam/match/area_matcher.h"
#include "slam/solve/two_view.h"

namespace lcv::slam {

struct InitializerOptions {
  AreaMatchOptions matching;
  int min_matches = 100;  // matches needed before a two-view solve is attempted
  // Two-view solver settings (slam/solve/two_view.h): inlier angle, parallax, point counts,
  // homography. The seed is replaced per attempt by seed + attempt number.
  TwoViewOptions two_view;
  std::uint64_t seed = 1;
  // Reference frames older than this (frames) are replaced by the current frame.
  int max_reference_age_frames = 30;
};

struct Initialization {
  // Pose of the current frame relative to the reference (reference = identity, |t| = 1).
  Rigid3d current_from_reference;
  // Triangulated matches: (reference keypoint index, current keypoint index) and the point in
  // the reference camera frame.
  std::vector<std::pair<int, int>> matches;
  std::vector<Eigen::Vector3d> points_in_reference;
  bool from_homography = false;
};

class Initializer {
 public:
  explicit Initializer(const InitializerOptions& options);

  bool has_reference() const { return has_reference_; }
  const Frame& reference() const { return reference_; }
  // Starts over with this frame as the reference.
  void SetReference(const Frame& frame);
  void Reset() { has_reference_ = false; }

  // Tries to initialize against the reference. Empty when it cannot (yet); the reason is in
  // last_failure(). Replaces the reference when too few matches survive or it is too old.
  std::optional<Initialization> TryInitialize(const Frame& current);
  const std::string& last_failure() const { return last_failure_; }

 private:
  InitializerOptions options_;
  Frame reference_;
  bool has_reference_ = false;
  std::vector<Eigen::Vector2f> predicted_px_;
  std::uint64_t attempts_ = 0;
  int reference_age_frames_ = 0;
  std::string last_failure_;
};

}  // namespace lcv::slam
