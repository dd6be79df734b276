#include "slam/optimize/slam_map_bundle.h"

#include <algorithm>
#include <map>
#include <set>
#include <utility>

#include "slam/geometry/line3.h"
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

namespace {

// LineCloudBundleOptions::virtual_sigma_px: the sigma of each server keyframe's camera, once
// per server keyframe of the problem, then on its virtual observations.
void SetVirtualSigmaInPixels(const SlamMap& map, double sigma_px, BundleProblem* problem) {
  if (!(sigma_px > 0.0)) return;
  std::vector<double> sigma(problem->server_keyframes.size(), 0.0);
  for (size_t s = 0; s < sigma.size(); ++s) {
    const SlamServerKeyframe* kf = map.FindServerKeyframe(problem->server_keyframes[s].id);
    if (kf == nullptr) continue;
    const auto camera = map.server_cameras().find(kf->camera_id);
    if (camera != map.server_cameras().end()) sigma[s] = sigma_px * PixelAngle(camera->second);
  }
  for (BundleVirtualObservation& v : problem->virtual_observations) {
    if (sigma[v.server_keyframe] > 0.0) {
      v.sqrt_information = Eigen::Matrix2d::Identity() / sigma[v.server_keyframe];
    }
  }
}

}  // namespace

std::vector<Id> AddLineCloudToBundle(const SlamMap& map, const LineCloudBundleOptions& options,
                                     BundleProblem* problem) {
  std::vector<Id> line_ids;
  std::map<Id, int> line_index;
  std::map<Id, int> restored_lines_seen;  // server keyframe -> X' lines it sees
  for (size_t i = 0; i < problem->lines.size(); ++i) {
    BundleLine& line = problem->lines[i];
    const Id line_id = map.FindLandmark(line.id)->line_id;
    line.fixed = false;
    line_ids.push_back(line_id);
    line_index[line_id] = static_cast<int>(i);
    for (const Id kf_id : map.FindLine(line_id)->server_keyframe_ids) {
      if (map.FindServerKeyframe(kf_id) != nullptr) ++restored_lines_seen[kf_id];
    }
  }
  std::set<Id> joined;  // server keyframes that join with their lines
  {
    std::vector<std::pair<int, Id>> by_count;
    for (const auto& [kf_id, count] : restored_lines_seen) by_count.emplace_back(-count, kf_id);
    std::sort(by_count.begin(), by_count.end());
    const size_t n = options.max_free_server_keyframes < 0
                         ? by_count.size()
                         : std::min(by_count.size(),
                                    static_cast<size_t>(options.max_free_server_keyframes));
    for (size_t k = 0; k < n; ++k) joined.insert(by_count[k].second);
  }
  std::map<Id, int> server_index;
  for (const auto& [kf_id, count] : restored_lines_seen) {
    if (!joined.count(kf_id)) continue;
    const SlamServerKeyframe& kf = *map.FindServerKeyframe(kf_id);
    BundleServerKeyframe s;
    s.id = kf_id;
    s.cam_from_world = kf.cam_from_world;
    s.cam_from_world.rotation.normalize();
    server_index[kf_id] = static_cast<int>(problem->server_keyframes.size());
    problem->server_keyframes.push_back(s);
    for (const Id line_id : kf.line_ids) {
      const SlamLine* line = map.FindLine(line_id);
      if (line == nullptr || line_index.count(line_id) || line->server_keyframe_ids.size() < 2) {
        continue;
      }
      BundleLine l;
      l.id = kInvalidId;  // no X': nothing to write back but the line
      l.line = line->line;
      l.information = line->information;
      l.fixed = false;
      line_index[line_id] = static_cast<int>(problem->lines.size());
      problem->lines.push_back(l);
      line_ids.push_back(line_id);
    }
  }
  // Fixed border: server keyframes that see a line of the problem and did not join.
  int num_fixed = 0;
  for (const auto& [line_id, index] : line_index) {
    for (const Id kf_id : map.FindLine(line_id)->server_keyframe_ids) {
      const SlamServerKeyframe* kf = map.FindServerKeyframe(kf_id);
      if (kf == nullptr || server_index.count(kf_id)) continue;
      BundleServerKeyframe s;
      s.id = kf_id;
      s.cam_from_world = kf->cam_from_world;
      s.cam_from_world.rotation.normalize();
      s.fixed = true;
      server_index[kf_id] = static_cast<int>(problem->server_keyframes.size());
      problem->server_keyframes.push_back(s);
      ++num_fixed;
    }
  }
  if (!options.free_server_keyframes) {
    for (BundleServerKeyframe& k : problem->server_keyframes) k.fixed = true;
  } else if (num_fixed < 2) {
    // The gauge: the joined server keyframes that see the fewest X' lines.
    std::vector<std::pair<int, Id>> by_count;
    for (const Id kf_id : joined) by_count.emplace_back(restored_lines_seen.at(kf_id), kf_id);
    std::sort(by_count.begin(), by_count.end());
    for (size_t k = 0; k < by_count.size() && num_fixed < 2; ++k, ++num_fixed) {
      problem->server_keyframes[server_index.at(by_count[k].second)].fixed = true;
    }
  }
  std::vector<std::pair<int, int>> pairs;
  for (const auto& [kf_id, index] : server_index) {
    for (const Id line_id : map.FindServerKeyframe(kf_id)->line_ids) {
      auto it = line_index.find(line_id);
      if (it != line_index.end()) pairs.emplace_back(index, it->second);
    }
  }
  if (!options.virtual_from_published) {
    MakeVirtualObservations(pairs, problem);
  } else {
    std::vector<Rigid3d> published_poses;
    for (const BundleServerKeyframe& s : problem->server_keyframes) {
      published_poses.push_back(map.FindServerKeyframe(s.id)->published_cam_from_world);
      published_poses.back().rotation.normalize();
    }
    std::vector<Line3d> published_lines;
    for (const Id line_id : line_ids) {
      published_lines.push_back(map.FindLine(line_id)->published_line);
    }
    MakeVirtualObservations(pairs, published_poses, published_lines, problem);
  }
  SetVirtualSigmaInPixels(map, options.virtual_sigma_px, problem);
  return line_ids;
}

void WriteBackLineCloud(const BundleProblem& problem, const std::vector<Id>& line_ids,
                        SlamMap* map) {
  for (size_t i = 0; i < problem.lines.size() && i < line_ids.size(); ++i) {
    SlamLine* line = map->FindLine(line_ids[i]);
    if (line == nullptr) continue;
    const Line3d& moved = problem.lines[i].line;
    const Line3d new_line(moved.anchor, moved.direction.normalized());
    line->MoveTo(Line3d(new_line.Project(line->line.anchor), new_line.direction));
  }
  for (const BundleServerKeyframe& s : problem.server_keyframes) {
    if (s.fixed) continue;
    auto kf = map->mutable_server_keyframes().find(s.id);
    if (kf == map->mutable_server_keyframes().end()) continue;
    kf->second.cam_from_world = s.cam_from_world;
    kf->second.cam_from_world.rotation.normalize();
  }
}

}  // namespace lcv::slam
