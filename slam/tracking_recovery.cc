// Tracker's recovery when the motion model fails (slam/tracking.h, step 3): the wide local-map
// search around pose hypotheses and P3P on its matches. Split from tracking.cc to keep files
// small.
#include <algorithm>
#include <vector>

#include "slam/match/epipolar_matcher.h"  // RadiansPerPixel
#include "slam/solve/absolute_pose.h"
#include "slam/tracking.h"

namespace lcv::slam {

namespace {

// A pose hypothesis kept while another one is tried on the same frame.
struct SavedPose {
  Rigid3d cam_from_world;
  std::vector<Id> landmark_ids;
  void Save(const Frame& frame) {
    cam_from_world = frame.cam_from_world;
    landmark_ids = frame.landmark_ids;
  }
  void Restore(Frame* frame) {
    frame->ResetMatches();
    frame->cam_from_world = cam_from_world;
    frame->landmark_ids = std::move(landmark_ids);
  }
};

}  // namespace

bool Tracker::AdoptReferenceLandmarks(const LocalMapSnapshot& snapshot) {
  if (snapshot.reference_source_frame_id != last_frame_.id ||
      snapshot.reference_landmark_ids.size() != last_frame_.landmark_ids.size()) {
    return false;
  }
  int added = 0;
  for (size_t i = 0; i < last_frame_.landmark_ids.size(); ++i) {
    const Id id = snapshot.reference_landmark_ids[i];
    if (id == kInvalidId || snapshot.FindLandmark(id) == nullptr) continue;
    added += last_frame_.landmark_ids[i] != id || last_frame_.is_outlier[i];
    last_frame_.landmark_ids[i] = id;
    last_frame_.is_outlier[i] = 0;
  }
  return added > 0;
}

Tracker::WeakMotionChoice Tracker::ChooseAfterWeakMotion(const LocalMapSnapshot& snapshot,
                                                         const Rigid3d& predicted,
                                                         bool motion_pose_ok, Frame* frame) {
  // A weak motion-model pose (a few inliers among many matches) may be a wrong minimum of the
  // motion-only BA: in a sharp turn one was accepted at 13 of 81 matches and tracked 42 points
  // where RecoverPose tracks 157 (synthetic loop, equirectangular, frame 8). The candidates are
  // scored as tracking will judge them: inliers after the local-map search at their pose.
  const int min_good = options_.tracking.min_recovered_inliers;
  int motion_score = -1;
  SavedPose motion;
  if (motion_pose_ok) {
    motion.Save(*frame);
    MatchLocalMap(snapshot, frame);
    motion_score = OptimizePose(snapshot, frame);
    if (motion_score > 0) motion.Save(*frame);
  }
  int recovered_score = RecoverPose(snapshot, predicted, frame);
  if (recovered_score < min_good && motion_score < min_good &&
      options_.tracking.window_free_recovery && velocity_ && velocity_dt_ > 0.0) {
    // Nothing near the prediction: the turn started or stopped between the two frames, and the
    // constant-velocity rotation is wrong by all of it (synthetic loop, fisheye, frame 27:
    // 21 degrees). The window-free search does not depend on the prediction.
    SavedPose recovered;
    recovered.Save(*frame);
    int appearance_score = TrackLastFrameByAppearance(snapshot, frame);
    if (appearance_score >= 10) {
      MatchLocalMap(snapshot, frame);
      appearance_score = OptimizePose(snapshot, frame);
    }
    // Any rotation, but not a jump: the centre moved at most window_free_max_travel times as
    // far as over the last frame interval (scaled to the elapsed time).
    const double intervals =
        std::max(1.0, (frame->timestamp - last_frame_.timestamp) / velocity_dt_);
    const double max_travel =
        options_.tracking.window_free_max_travel * intervals * velocity_->translation.norm();
    if ((frame->cam_from_world.Center() - last_frame_.cam_from_world.Center()).norm() > max_travel) {
      appearance_score = -1;
    }
    if (appearance_score > recovered_score) {
      recovered_score = appearance_score;
    } else {
      recovered.Restore(frame);
    }
  }
  if (recovered_score >= 10 && recovered_score >= motion_score) return {recovered_score, false};
  if (motion_pose_ok) motion.Restore(frame);
  return {motion_score, true};
}

int Tracker::RecoverPose(const LocalMapSnapshot& snapshot, const Rigid3d& predicted,
                          Frame* frame) {
  // Wide projection search around a pose hypothesis, then P3P RANSAC on the matches (ORB-SLAM's
  // relocalization accepts 10 P3P inliers; the local-map search that follows decides). After a
  // gap the extrapolated rotation is the least reliable part of the prediction (a camera
  // turning when the images stopped may have stopped turning since: at a street corner the
  // constant-velocity rotation overshoots by tens of degrees within a second). The hypotheses
  // keep the extrapolated centre and take 1, 1/2 and 0 of the extrapolated rotation; the one
  // with the most inliers wins.
  const Eigen::Quaterniond last_rotation = last_frame_.cam_from_world.rotation;
  const Eigen::Vector3d predicted_center = predicted.Center();
  const double turned = last_rotation.angularDistance(predicted.rotation);
  std::vector<double> fractions = {1.0};
  if (turned > options_.tracking.recovery_rotation_hypothesis_rad) fractions = {1.0, 0.5, 0.0};
  // The best hypothesis so far: its pose and matches (motion-only BA leaves no outlier flags).
  int best_inliers = -1;
  Rigid3d best_pose;
  std::vector<Id> best_landmark_ids;
  for (const double fraction : fractions) {
    Rigid3d hypothesis;
    hypothesis.rotation = last_rotation.slerp(fraction, predicted.rotation).normalized();
    hypothesis.translation = -(hypothesis.rotation * predicted_center);
    frame->ResetMatches();
    frame->cam_from_world = hypothesis;
    MatchLocalMap(snapshot, frame, /*wide=*/true);
    int inliers = PoseFromMatches(snapshot, frame);
    // Scored as tracking will judge it: inliers after the ordinary local-map search at the pose.
    if (inliers >= 10) {
      MatchLocalMap(snapshot, frame);
      inliers = OptimizePose(snapshot, frame);
    }
    if (inliers > best_inliers) {
      best_inliers = inliers;
      best_pose = frame->cam_from_world;
      best_landmark_ids = frame->landmark_ids;
    }
  }
  frame->ResetMatches();
  frame->cam_from_world = best_pose;
  frame->landmark_ids = std::move(best_landmark_ids);
  return best_inliers;
}

int Tracker::PoseFromMatches(const LocalMapSnapshot& snapshot, Frame* frame) {
  std::vector<Eigen::Vector3d> bearings, points;
  std::vector<int> keypoints;
  for (int i = 0; i < frame->num_keypoints(); ++i) {
    const Id id = frame->landmark_ids[i];
    if (id == kInvalidId) continue;
    const SnapshotLandmark* landmark = snapshot.FindLandmark(id);
    if (landmark == nullptr || frame->bearings[i].squaredNorm() < 0.5) {
      frame->landmark_ids[i] = kInvalidId;
      continue;
    }
    bearings.push_back(frame->bearings[i]);
    points.push_back(landmark->position_in_world);
    keypoints.push_back(i);
  }
  if (bearings.size() < 10) return 0;
  AbsolutePoseOptions pose_options;
  pose_options.ransac.random_seed = options_.seed + frame->id;
  pose_options.ransac.max_error = 0.0;
  // 3 px through the camera's angular resolution: a fixed angle would be ~0.4 px on a 640 px
  // equirectangular image and 1.5 px on a 640 px perspective one.
  pose_options.max_angular_error_rad = 3.0 * RadiansPerPixel(*frame->camera);
  pose_options.ransac.max_num_trials = 300;
  pose_options.min_num_inliers = 10;
  const AbsolutePoseResult result = EstimateAbsolutePose(bearings, points, pose_options);
  if (!result.success) return 0;
  frame->cam_from_world = result.cam_from_world;
  for (size_t k = 0; k < keypoints.size(); ++k) {
    if (!result.inlier_mask[k]) frame->landmark_ids[keypoints[k]] = kInvalidId;
  }
  return OptimizePose(snapshot, frame);
}

}  // namespace lcv::slam
