#include "slam/match/keyframe_projection_matcher.h"

#include <cmath>
#include <limits>

#include "slam/util/error.h"

namespace lcv::slam {

std::vector<KeyframeProjectionMatch> MatchLandmarksIntoKeyframe(
    const SlamMap& map, const SlamKeyframe& keyframe, const Sim3d& cam_from_world,
    const std::vector<Id>& landmark_ids, const KeyframeProjectionOptions& options,
    const std::vector<char>* keypoint_blocked) {
  const int num_keypoints = static_cast<int>(keyframe.keypoints.size());
  LCV_CHECK(keypoint_blocked == nullptr ||
            static_cast<int>(keypoint_blocked->size()) == num_keypoints);
  LCV_CHECK(keyframe.camera != nullptr) << "keyframe " << keyframe.id;
  const Camera& camera = *keyframe.camera;
  const ScaleLevels& levels = keyframe.scale_levels;
  // Rigid part with the same projections: s R X + t = s (R X + t / s).
  const Rigid3d projection_pose(cam_from_world.rotation, cam_from_world.translation /
                                                             cam_from_world.scale);
  const Eigen::Vector3d center = projection_pose.Center();
  const double cos_max_view = std::cos(options.max_view_angle_deg * M_PI / 180.0);

  // Per keypoint: best distance and landmark so far.
  std::vector<int> best_distance(num_keypoints, std::numeric_limits<int>::max());
  std::vector<Id> best_landmark(num_keypoints, kInvalidId);
  std::vector<int> window;
  for (const Id landmark_id : landmark_ids) {
    const SlamLandmark* landmark = map.FindLandmark(landmark_id);
    if (landmark == nullptr) continue;
    bool seen = false;
    for (const Observation& o : landmark->observations) seen |= o.keyframe_id == keyframe.id;
    if (seen) continue;
    const Eigen::Vector3d p_in_cam = projection_pose * landmark->position_in_world;
    const Eigen::Vector3d ray = landmark->position_in_world - center;
    const double distance = ray.norm();
    if (!(distance > 0.0)) continue;
    if (distance < 0.8 * landmark->min_distance || distance > 1.2 * landmark->max_distance) {
      continue;
    }
    if (ray.dot(landmark->mean_viewing_direction) < cos_max_view * distance) continue;
    const std::optional<Eigen::Vector2d> px = camera.Project(p_in_cam);
    if (!px || !camera.InImage(*px)) continue;
    const int octave = levels.PredictOctave(distance, landmark->max_distance);
    const float radius = options.radius_factor * static_cast<float>(levels.Scale(octave));
    keyframe.grid.Query(keyframe.keypoints, static_cast<float>(px->x()),
                        static_cast<float>(px->y()), radius, std::max(0, octave - 1), octave,
                        &window);
    int best = options.max_hamming_distance + 1;
    int best_index = -1;
    for (const int i : window) {
      if (keypoint_blocked != nullptr && (*keypoint_blocked)[i]) continue;
      const int d = HammingDistance(landmark->descriptor, keyframe.descriptors[i]);
      if (d < best) {
        best = d;
        best_index = i;
      }
    }
    if (best_index < 0) continue;
    if (best < best_distance[best_index] ||
        (best == best_distance[best_index] && landmark_id < best_landmark[best_index])) {
      best_distance[best_index] = best;
      best_landmark[best_index] = landmark_id;
    }
  }
  std::vector<KeyframeProjectionMatch> matches;
  for (int i = 0; i < num_keypoints; ++i) {
    if (best_landmark[i] != kInvalidId) matches.push_back({i, best_landmark[i], best_distance[i]});
  }
  return matches;
}

}  // namespace lcv::slam
