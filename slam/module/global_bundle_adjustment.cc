#include "slam/module/global_bundle_adjustment.h"

#include <algorithm>
#include <map>
#include <set>


#include "slam/optimize/residuals.h"
#include "slam/optimize/slam_map_bundle.h"

namespace lcv::slam {

namespace {

// The server side of a line-cloud job (see CaptureGlobalBA): free lines and server keyframes,
// fixed border server keyframes, virtual observations.
void AddLineCloud(const SlamMap& map, bool free_server_keyframes, GlobalBAJob* job) {
  BundleProblem& problem = job->problem;
  std::map<Id, int> line_index;
  std::map<Id, int> restored_lines_seen;  // server keyframe -> X' lines it sees
  for (size_t i = 0; i < problem.lines.size(); ++i) {
    BundleLine& line = problem.lines[i];
    const Id line_id = map.FindLandmark(line.id)->line_id;
    line.fixed = false;
    job->line_ids.push_back(line_id);
    line_index[line_id] = static_cast<int>(i);
    for (const Id kf_id : map.FindLine(line_id)->server_keyframe_ids) {
      if (map.FindServerKeyframe(kf_id) != nullptr) ++restored_lines_seen[kf_id];
    }
  }
  // Free server keyframes (they see an X' line) and every line they see.
  std::map<Id, int> server_index;
  for (const auto& [kf_id, count] : restored_lines_seen) {
    const SlamServerKeyframe& kf = *map.FindServerKeyframe(kf_id);
    BundleServerKeyframe s;
    s.id = kf_id;
    s.cam_from_world = kf.cam_from_world;
    s.cam_from_world.rotation.normalize();
    server_index[kf_id] = static_cast<int>(problem.server_keyframes.size());
    problem.server_keyframes.push_back(s);
    for (const Id line_id : kf.line_ids) {
      const SlamLine* line = map.FindLine(line_id);
      // A line without X' is held only by its virtual observations, 2 per server keyframe for
      // its 4 degrees of freedom: seen by one server keyframe it is free to turn and slide in
      // that keyframe's view plane and holds nothing (measured: such lines wandered 0.5 m).
      if (line == nullptr || line_index.count(line_id) || line->server_keyframe_ids.size() < 2) {
        continue;
      }
      BundleLine l;
      l.id = kInvalidId;  // no X': nothing to write back but the line
      l.line = line->line;
      l.information = line->information;
      l.fixed = false;
      line_index[line_id] = static_cast<int>(problem.lines.size());
      problem.lines.push_back(l);
      job->line_ids.push_back(line_id);
    }
  }
  // Fixed border: server keyframes that see a line of the job but no X' line.
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
      server_index[kf_id] = static_cast<int>(problem.server_keyframes.size());
      problem.server_keyframes.push_back(s);
      ++num_fixed;
    }
  }
  if (!free_server_keyframes) {
    for (BundleServerKeyframe& k : problem.server_keyframes) k.fixed = true;
  } else if (num_fixed < 2) {
    // The gauge: the free server keyframes that see the fewest X' lines.
    std::vector<std::pair<int, Id>> by_count;
    for (const auto& [kf_id, count] : restored_lines_seen) by_count.emplace_back(count, kf_id);
    std::sort(by_count.begin(), by_count.end());
    for (size_t k = 0; k < by_count.size() && num_fixed < 2; ++k, ++num_fixed) {
      problem.server_keyframes[server_index.at(by_count[k].second)].fixed = true;
    }
  }
  std::vector<std::pair<int, int>> pairs;
  for (const auto& [kf_id, index] : server_index) {
    for (const Id line_id : map.FindServerKeyframe(kf_id)->line_ids) {
      auto it = line_index.find(line_id);
      if (it != line_index.end()) pairs.emplace_back(index, it->second);
    }
  }
  MakeVirtualObservations(pairs, &problem);
  job->line_cloud = true;
}

}  // namespace

GlobalBAJob CaptureGlobalBA(const SlamMap& map, bool free_line_cloud,
                           bool free_server_keyframes) {
  GlobalBAJob job;
  job.num_loop_edges = map.loop_edges().size();
  SlamMapBundleBuilder builder(map, &job.problem);
  const bool line_cloud =
      free_line_cloud && map.HasLineCloud() && map.ActiveSegmentRegistered();
  // The active segment only: inactive ones are in frames of their own (slam_map.h).
  const int segment = map.active_segment();
  for (const auto& [id, kf] : map.keyframes()) {
    if (kf.segment == segment) {
      builder.AddKeyframe(id, /*fixed=*/!line_cloud && id == map.first_keyframe_id());
    }
  }
  for (const auto& [id, landmark] : map.landmarks()) {
    if (landmark.segment == segment) builder.AddLandmark(id);
  }
  job.links = builder.links();
  if (line_cloud) {
    // The builder makes a BundleLine for each X' only: without one, nothing ties the client to
    // the lines.
    if (!job.problem.lines.empty()) {
      AddLineCloud(map, free_server_keyframes, &job);
    } else if (!job.problem.keyframes.empty()) {
      job.problem.keyframes.front().fixed = true;
    }
  }
  return job;
}

BundleReport SolveGlobalBA(const GlobalBAOptions& options, GlobalBAJob* job) {
  BundleOptions bundle;
  bundle.max_iterations = options.max_iterations;
  bundle.max_refine_iterations = options.max_iterations;
  bundle.refine_without_outliers = options.refine_without_outliers;
  bundle.num_threads = options.num_threads;
  bundle.virtual_sigma_rad = options.virtual_sigma_rad;
  if (options.derived_virtual_information) {
    for (BundleVirtualObservation& v : job->problem.virtual_observations) {
      const BundleLine& line = job->problem.lines[v.line];
      v.sqrt_information = VirtualObservationSqrtInformation(
          job->problem.server_keyframes[v.server_keyframe].cam_from_world, line.line,
          v.observed_normal, line.information, options.virtual_sigma_rad);
    }
  }
  job->report = SolveBundleAdjustment(bundle, &job->problem);
  job->solved = true;
  return job->report;
}

bool ApplyGlobalBA(const GlobalBAJob& job, SlamMap* map) {
  if (!job.solved || !job.report.success) return false;
  if (map->loop_edges().size() != job.num_loop_edges) return false;
  std::map<Id, Rigid3d> optimized;
  for (const BundleKeyframe& k : job.problem.keyframes) optimized[k.id] = k.cam_from_world;

  // New poses: captured keyframes from the solve, the others through the spanning tree (parents
  // are older, so a walk from the first keyframe reaches every keyframe of the tree).
  std::map<Id, Rigid3d> before, after;
  for (const auto& [id, kf] : map->keyframes()) before[id] = kf.cam_from_world;
  std::vector<Id> stack;
  const Id root = map->first_keyframe_id();
  if (map->FindKeyframe(root) != nullptr) {
    auto it = optimized.find(root);
    after[root] = it != optimized.end() ? it->second : before.at(root);
    stack.push_back(root);
  }
  while (!stack.empty()) {
    const Id parent = stack.back();
    stack.pop_back();
    for (const Id child : map->FindKeyframe(parent)->child_ids) {
      if (map->FindKeyframe(child) == nullptr || after.count(child)) continue;
      auto it = optimized.find(child);
      after[child] = it != optimized.end()
                         ? it->second
                         : (before.at(child) * before.at(parent).Inverse()) * after.at(parent);
      stack.push_back(child);
    }
  }
  // Keyframes the tree does not reach (none in a consistent map) keep a captured value if any.
  for (const auto& [id, pose] : before) {
    if (after.count(id)) continue;
    auto it = optimized.find(id);
    after[id] = it != optimized.end() ? it->second : pose;
  }

  const std::vector<Id> written = WriteBackLandmarkPositions(job.problem, map);
  const std::set<Id> captured_points(written.begin(), written.end());
  for (auto& [id, landmark] : map->mutable_landmarks()) {
    if (captured_points.count(id)) continue;
    Id anchor = landmark.reference_keyframe_id;
    if (!before.count(anchor)) {
      anchor = landmark.observations.empty() ? kInvalidId
                                             : landmark.observations.front().keyframe_id;
    }
    if (!before.count(anchor)) continue;
    landmark.position_in_world =
        after.at(anchor).Inverse() * (before.at(anchor) * landmark.position_in_world);
  }
  for (const auto& [id, pose] : after) {
    Rigid3d& cam_from_world = map->FindKeyframe(id)->cam_from_world;
    cam_from_world = pose;
    cam_from_world.rotation.normalize();
  }

  std::set<Id> touched;
  for (size_t k = 0; k < job.problem.observations.size(); ++k) {
    if (!job.problem.observations[k].outlier) continue;
    const GlobalBAJob::Link& link = job.links[k];
    const SlamKeyframe* kf = map->FindKeyframe(link.keyframe_id);
    if (kf == nullptr || kf->landmark_ids[link.keypoint_index] != link.landmark_id) continue;
    const SlamLandmark* landmark = map->FindLandmark(link.landmark_id);
    if (landmark != nullptr) {
      for (const Observation& o : landmark->observations) touched.insert(o.keyframe_id);
    }
    map->RemoveObservation(link.landmark_id, link.keyframe_id, 2);
  }
  if (job.line_cloud) {
    for (size_t i = 0; i < job.problem.lines.size(); ++i) {
      SlamLine* line = map->FindLine(job.line_ids[i]);
      if (line == nullptr) continue;
      const Line3d& moved = job.problem.lines[i].line;
      const Eigen::Vector3d direction = moved.direction.normalized();
      line->information = TurnLineInformation(line->information, line->line.direction, direction);
      const Line3d new_line(moved.anchor, direction);
      line->line = Line3d(new_line.Project(line->line.anchor), direction);
    }
    for (const BundleServerKeyframe& s : job.problem.server_keyframes) {
      if (s.fixed) continue;
      auto kf = map->mutable_server_keyframes().find(s.id);
      if (kf == map->mutable_server_keyframes().end()) continue;
      kf->second.cam_from_world = s.cam_from_world;
      kf->second.cam_from_world.rotation.normalize();
    }
  }
  for (const auto& [id, landmark] : map->landmarks()) map->UpdateLandmarkGeometry(id);
  for (const Id id : touched) map->UpdateCovisibility(id);
  return true;
}

}  // namespace lcv::slam
