// LocalMapper's duplicate fusion (slam/local_mapping.h): the new keyframe's landmarks projected
// into its first and second covisibility rings and theirs into it, merged or linked. Split from
// local_mapping.cc to keep files small.
#include <cmath>
#include <set>
#include <vector>

#include "slam/local_mapping.h"

namespace lcv::slam {

namespace {

constexpr double kChi2TwoDof = 5.991;

}  // namespace

int LocalMapper::FuseInto(const std::vector<Id>& landmark_ids, Id keyframe_id) {
  SlamKeyframe& kf = map_.mutable_keyframes().at(keyframe_id);
  if (kf.loaded && !options_.mapping.use_loaded_keypoints) return 0;
  const ScaleLevels& levels = kf.scale_levels;
  const Eigen::Vector3d center = kf.Center();
  const double cos_max_view = std::cos(options_.tracking.max_view_angle_deg * M_PI / 180.0);
  int fused = 0;
  for (const Id landmark_id : landmark_ids) {
    const SlamLandmark* landmark = map_.FindLandmark(landmark_id);
    if (landmark == nullptr) continue;
    bool seen = false;
    for (const Observation& o : landmark->observations) seen |= o.keyframe_id == keyframe_id;
    if (seen) continue;
    const Eigen::Vector3d p_in_cam = kf.cam_from_world * landmark->position_in_world;
    const double distance = p_in_cam.norm();
    if (!(distance > 0.0)) continue;
    if (distance < 0.8 * landmark->min_distance || distance > 1.2 * landmark->max_distance) continue;
    if ((landmark->position_in_world - center).dot(landmark->mean_viewing_direction) <
        cos_max_view * distance) {
      continue;
    }
    const std::optional<Eigen::Vector2d> px = camera_.Project(p_in_cam);
    if (!px || !camera_.InImage(*px)) continue;
    const int octave = levels.PredictOctave(distance, landmark->max_distance);
    const float radius = static_cast<float>(3.0 * levels.Scale(octave));
    kf.grid.Query(kf.keypoints, static_cast<float>(px->x()), static_cast<float>(px->y()), radius,
                  std::max(0, octave - 1), octave + 1, &window_);
    int best = 51;  // ORB-SLAM's TH_LOW + 1
    int best_index = -1;
    for (const int i : window_) {
      const Keypoint& kp = kf.keypoints[i];
      const double e2 = (*px - Eigen::Vector2d(kp.x, kp.y)).squaredNorm();
      if (e2 * levels.InverseSigma2(kp.octave) > kChi2TwoDof) continue;
      const int d = HammingDistance(landmark->descriptor, kf.descriptors[i]);
      if (d < best) {
        best = d;
        best_index = i;
      }
    }
    if (best_index < 0) continue;
    const Id existing = kf.landmark_ids[best_index];
    const SlamLandmark* existing_landmark =
        existing == kInvalidId ? nullptr : map_.FindLandmark(existing);
    if (existing_landmark != nullptr) {
      if (existing_landmark->NumObservations() > landmark->NumObservations()) {
        map_.ReplaceLandmark(landmark_id, existing);
      } else {
        map_.ReplaceLandmark(existing, landmark_id);
      }
    } else {
      map_.AddObservation(landmark_id, keyframe_id, best_index);
      map_.UpdateLandmarkGeometry(landmark_id);
    }
    ++fused;
  }
  return fused;
}

int LocalMapper::FuseDuplicates(Id keyframe_id) {
  std::vector<Id> targets;
  std::set<Id> target_set{keyframe_id};
  for (const Id id : map_.CovisibleKeyframes(keyframe_id, options_.mapping.max_triangulation_neighbours)) {
    if (target_set.insert(id).second) targets.push_back(id);
    for (const Id second : map_.CovisibleKeyframes(id, 5)) {
      if (target_set.insert(second).second) targets.push_back(second);
    }
  }
  int fused = 0;
  std::vector<Id> own;
  for (const Id id : map_.keyframes().at(keyframe_id).landmark_ids) {
    if (id != kInvalidId) own.push_back(id);
  }
  for (const Id target : targets) fused += FuseInto(own, target);

  std::set<Id> theirs;
  for (const Id target : targets) {
    const SlamKeyframe* kf = map_.FindKeyframe(target);
    if (kf == nullptr) continue;
    for (const Id id : kf->landmark_ids) {
      if (id != kInvalidId) theirs.insert(id);
    }
  }
  fused += FuseInto(std::vector<Id>(theirs.begin(), theirs.end()), keyframe_id);

  for (const Id id : map_.keyframes().at(keyframe_id).landmark_ids) {
    if (id != kInvalidId) map_.UpdateLandmarkGeometry(id);
  }
  map_.UpdateCovisibility(keyframe_id);
  for (const Id target : targets) {
    if (map_.FindKeyframe(target) != nullptr) map_.UpdateCovisibility(target);
  }
  return fused;
}

}  // namespace lcv::slam
