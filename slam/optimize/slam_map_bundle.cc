#include "slam/optimize/slam_map_bundle.h"

#include "slam/util/error.h"

namespace lcv::slam {

SlamMapBundleBuilder::SlamMapBundleBuilder(const SlamMap& map, BundleProblem* problem)
    : map_(map), problem_(problem) {}

int SlamMapBundleBuilder::AddKeyframe(Id id, bool fixed) {
  auto it = keyframe_index_.find(id);
  if (it != keyframe_index_.end()) return it->second;
  const SlamKeyframe* kf = map_.FindKeyframe(id);
  LCV_CHECK(kf != nullptr) << "keyframe " << id;
  BundleKeyframe k;
  k.id = id;
  k.cam_from_world = kf->cam_from_world;
  k.cam_from_world.rotation.normalize();
  k.camera = kf->camera;
  k.fixed = fixed;
  problem_->keyframes.push_back(k);
  const int index = static_cast<int>(problem_->keyframes.size()) - 1;
  keyframe_index_[id] = index;
  return index;
}

bool SlamMapBundleBuilder::AddLandmark(Id landmark_id) {
  const SlamLandmark* landmark = map_.FindLandmark(landmark_id);
  if (landmark == nullptr || landmark->observations.empty()) return false;
  int index = 0;
  const bool on_line = landmark->IsRestored();
  if (on_line) {
    const SlamLine* line = map_.FindLine(landmark->line_id);
    if (line == nullptr) return false;
    BundleLine bundle_line;
    bundle_line.id = landmark_id;
    bundle_line.line = line->line;
    bundle_line.information = line->information;
    bundle_line.restored_point = landmark->position_in_world;
    bundle_line.fixed = true;
    index = static_cast<int>(problem_->lines.size());
    problem_->lines.push_back(bundle_line);
  } else {
    BundlePoint point;
    point.id = landmark_id;
    point.position = landmark->position_in_world;
    index = static_cast<int>(problem_->points.size());
    problem_->points.push_back(point);
  }
  for (const Observation& o : landmark->observations) {
    const int k = AddKeyframe(o.keyframe_id, /*fixed=*/true);
    const SlamKeyframe& kf = *map_.FindKeyframe(o.keyframe_id);
    const Keypoint& kp = kf.keypoints[o.keypoint_index];
    BundleObservation obs;
    obs.keyframe = k;
    obs.landmark = index;
    obs.on_line = on_line;
    obs.observed_px = Eigen::Vector2d(kp.x, kp.y);
    obs.information = kf.scale_levels.InverseSigma2(kp.octave);
    obs.outlier = !kf.camera->Project(kf.cam_from_world * landmark->position_in_world);
    problem_->observations.push_back(obs);
    links_.push_back({landmark_id, o.keyframe_id, static_cast<int>(o.keypoint_index)});
  }
  return true;
}

std::vector<Id> WriteBackLandmarkPositions(const BundleProblem& problem, SlamMap* map) {
  std::vector<Id> written;
  written.reserve(problem.points.size() + problem.lines.size());
  for (const BundlePoint& point : problem.points) {
    SlamLandmark* landmark = map->FindLandmark(point.id);
    if (landmark == nullptr) continue;
    landmark->position_in_world = point.position;
    written.push_back(point.id);
  }
  for (const BundleLine& line : problem.lines) {
    SlamLandmark* landmark = map->FindLandmark(line.id);
    if (landmark == nullptr) continue;
    landmark->position_in_world = line.restored_point;
    written.push_back(line.id);
  }
  return written;
}

}  // namespace lcv::slam
