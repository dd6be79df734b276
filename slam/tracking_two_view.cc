// Tracker's two-view step (slam/tracking.h, step 3): when neither the motion model nor the
// recoveries find the frame in the map right after a tracked frame, the relative pose between
// the last frame and this one from their 2D-2D matches (essential matrix on bearings,
// slam/solve/two_view.h), its scale from the map points the two views share, else from the
// last interval's travel. Split from tracking.cc to keep files small.
#include <algorithm>
#include <optional>
#include <utility>
#include <vector>

#include "slam/match/frame_matcher.h"
#include "slam/solve/two_view.h"
#include "slam/tracking.h"

namespace lcv::slam {

namespace {

constexpr double kChi2TwoDof = 5.991;

}  // namespace

bool Tracker::TwoViewAllowed() const {
  // Not twice in a row when the first tracked no map point, and not more than
  // two_view_max_consecutive times in a row: the step's keyframe gives the next frame ~100
  // points to track (frame 30 of the sharp turn: 26-27), so frames that keep finding none or a
  // handful of them mean the pose before was wrong. Live, after a camera interruption (fisheye
  // s2, frames 12-39 dropped), such chains posed 20-57 frames in a row with 0-7 map points, one
  // ending 504 m off. In 6661 earlier runs with per-frame stats the step posed at most 2 frames
  // in a row, and the first of two tracked 2-371 map points.
  return options_.tracking.two_view_recovery && !localization_only_ && has_last_frame_ &&
         last_frame_.has_pose && velocity_ && velocity_dt_ > 0.0 &&
         !last_frame_two_view_without_map_ &&
         consecutive_two_view_frames_ < options_.tracking.two_view_max_consecutive;
}

int Tracker::TrackByTwoView(const LocalMapSnapshot& snapshot, Frame* frame) {
  const TrackingSettings& settings = options_.tracking;
  // The frames may be tens of degrees apart: matched by descriptor alone (no window).
  const std::vector<std::pair<int, int>> pairs = MatchFramesByDescriptor(last_frame_, *frame);
  if (static_cast<int>(pairs.size()) < settings.two_view_min_points) return -1;
  std::vector<Eigen::Vector3d> bearings1, bearings2;
  bearings1.reserve(pairs.size());
  bearings2.reserve(pairs.size());
  for (const auto& [i, j] : pairs) {
    bearings1.push_back(last_frame_.bearings[i]);
    bearings2.push_back(frame->bearings[j]);
  }
  // The initializer's solver and inlier threshold, with gates for one pose instead of a new
  // map (TrackingSettings). The essential matrix only: the homography's two-fold planar
  // ambiguity rejected the right motion in a 32-degree turn (synthetic loop, perspective, frame
  // 73), and a motion too small for the essential matrix would triangulate nothing anyway.
  TwoViewOptions two_view = options_.initializer.two_view;
  two_view.random_seed = options_.seed + frame->id;
  two_view.use_homography = false;
  two_view.min_num_triangulated = settings.two_view_min_points;
  two_view.parallax_rank = settings.two_view_parallax_rank;
  two_view.parallax_threshold_deg = settings.two_view_parallax_deg;
  two_view.min_point_parallax_deg = std::min(two_view.min_point_parallax_deg,
                                             settings.two_view_parallax_deg);
  two_view.min_triangulated_ratio = settings.two_view_min_triangulated_ratio;
  const TwoViewGeometry geometry = EstimateTwoViewGeometry(bearings1, bearings2, two_view);
  if (!geometry.success) return -1;

  // Scale: the last frame's map points among the triangulated pairs, their distance from the
  // last camera against the unit-baseline triangulation's (median). Too few of them (the usual
  // case in a sharp turn: that is why the map lost the frame): the last interval's travel.
  std::vector<double> ratios;
  for (size_t k = 0; k < pairs.size(); ++k) {
    if (!geometry.triangulated[k]) continue;
    const int i = pairs[k].first;
    const Id id = last_frame_.landmark_ids[i];
    if (id == kInvalidId || last_frame_.is_outlier[i]) continue;
    const SnapshotLandmark* landmark = snapshot.FindLandmark(id);
    if (landmark == nullptr) continue;
    const Eigen::Vector3d in_last = last_frame_.cam_from_world * landmark->position_in_world;
    const double unit_distance = geometry.points_in_cam1[k].norm();
    if (!(unit_distance > 0.0) || in_last.dot(last_frame_.bearings[i]) <= 0.0) continue;
    ratios.push_back(in_last.norm() / unit_distance);
  }
  constexpr size_t kMinScalePoints = 5;
  const double intervals =
      std::max(1.0, (frame->timestamp - last_frame_.timestamp) / velocity_dt_);
  const double last_travel = intervals * velocity_->translation.norm();
  double baseline = last_travel;
  if (ratios.size() >= kMinScalePoints) {
    std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
    baseline = ratios[ratios.size() / 2];
  }
  // Not a jump (as for the window-free recovery): a kidnapped camera is relocalization's.
  if (!(baseline > 0.0) || baseline > settings.window_free_max_travel * last_travel) return -1;
  Rigid3d current_from_last = geometry.cam2_from_cam1;
  current_from_last.translation *= baseline;
  frame->ResetMatches();
  frame->cam_from_world = current_from_last * last_frame_.cam_from_world;
  frame->cam_from_world.rotation.normalize();
  frame->has_pose = true;

  // The map points in view: with enough of them motion-only BA refines the pose as for any
  // tracked frame; with few (a handful in the turn) the two-view pose stays, and they are kept
  // where they reproject (they link the keyframe to the map).
  const int matches = MatchLocalMap(snapshot, frame);
  if (matches >= settings.min_recovered_inliers) {
    const Rigid3d two_view_pose = frame->cam_from_world;
    const std::vector<Id> two_view_matches = frame->landmark_ids;
    const int inliers = OptimizePose(snapshot, frame);
    if (inliers >= settings.min_recovered_inliers) return inliers;
    frame->ResetMatches();
    frame->cam_from_world = two_view_pose;
    frame->landmark_ids = two_view_matches;
  }
  int inliers = 0;
  for (int i = 0; i < frame->num_keypoints(); ++i) {
    const Id id = frame->landmark_ids[i];
    if (id == kInvalidId) continue;
    const SnapshotLandmark* landmark = snapshot.FindLandmark(id);
    const Keypoint& kp = frame->keypoints[i];
    std::optional<Eigen::Vector2d> px;
    if (landmark != nullptr) {
      px = frame->camera->Project(frame->cam_from_world * landmark->position_in_world);
    }
    if (px && (*px - Eigen::Vector2d(kp.x, kp.y)).squaredNorm() *
                      frame->scale_levels.InverseSigma2(kp.octave) <=
                  kChi2TwoDof) {
      ++inliers;
    } else {
      frame->landmark_ids[i] = kInvalidId;
    }
  }
  return inliers;
}

}  // namespace lcv::slam
