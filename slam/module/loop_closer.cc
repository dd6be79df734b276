#include "slam/module/loop_closer.h"

#include <algorithm>
#include <chrono>
#include <limits>
#include <map>
#include <set>

#include "slam/match/keyframe_projection_matcher.h"
#include "slam/solve/umeyama.h"

namespace lcv::slam {
namespace {

Rigid3d ToRigid(const Sim3d& cam_from_world) {
  return Rigid3d(cam_from_world.rotation.normalized(),
                 cam_from_world.translation / cam_from_world.scale);
}

// Links landmark `into` to keypoint `index` of a keyframe; a different landmark held there is
// replaced by `into` everywhere (duplicate fusion). Returns true when the map changed.
bool FuseAt(Id keyframe_id, int index, Id into, SlamMap* map) {
  if (map->FindLandmark(into) == nullptr) return false;
  const Id current = map->FindKeyframe(keyframe_id)->landmark_ids[index];
  if (current == into) return false;
  if (current != kInvalidId && map->FindLandmark(current) != nullptr) {
    map->ReplaceLandmark(current, into);
    return true;
  }
  if (!map->AddObservation(into, keyframe_id, index)) return false;  // seen at another keypoint
  map->UpdateLandmarkGeometry(into);
  return true;
}

std::pair<Id, Id> Ordered(Id a, Id b) { return a < b ? std::make_pair(a, b) : std::make_pair(b, a); }

// Poses of the segment's keyframes read from a map file (LoopCloserOptions::keep_loaded_datum).
std::map<Id, Rigid3d> LoadedPoses(const SlamMap& map, int segment) {
  std::map<Id, Rigid3d> poses;
  for (const auto& [id, kf] : map.keyframes()) {
    if (kf.loaded && kf.segment == segment) poses[id] = kf.cam_from_world;
  }
  return poses;
}

// Moves the segment by the similarity that takes the listed keyframes back onto the given poses
// (AlignMapDatum). Nothing when fewer than 2 of them are left.
void RestoreLoadedDatum(const std::map<Id, Rigid3d>& captured, int segment, SlamMap* map) {
  std::vector<Rigid3d> now, before;
  for (const auto& [id, pose] : captured) {
    const SlamKeyframe* kf = map->FindKeyframe(id);
    if (kf == nullptr || kf->segment != segment) continue;
    now.push_back(kf->cam_from_world);
    before.push_back(pose);
  }
  Sim3d before_from_now;
  if (!AlignMapDatum(now, before, &before_from_now)) return;
  map->MoveSegment(segment, segment, before_from_now);
}

}  // namespace

bool MergeSegmentsForLoop(LoopDetection* loop, SlamMap* map) {
  const SlamKeyframe* query = map->FindKeyframe(loop->query_keyframe_id);
  const SlamKeyframe* match = map->FindKeyframe(loop->match_keyframe_id);
  if (query == nullptr || match == nullptr || query->segment == match->segment) return false;
  // The detection maps the match's world into the query camera (with the query's scale):
  // S_c * X_match = T_q * X_query, so X_match = S_c^-1 * T_q * X_query.
  const Sim3d match_world_from_query_world =
      loop->corrected_query_cam_from_world.Inverse() * Sim3d(query->cam_from_world);
  map->MoveSegment(query->segment, match->segment, match_world_from_query_world);
  loop->corrected_query_cam_from_world = Sim3d(query->cam_from_world);  // moved with it
  return true;
}

NeighbourhoodCorrection CorrectNeighbourhood(Id query_id,
                                             const Sim3d& corrected_query_cam_from_world,
                                             SlamMap* map) {
  NeighbourhoodCorrection n;
  map->UpdateCovisibility(query_id);
  n.keyframes.push_back(query_id);
  for (const Id id : map->CovisibleKeyframes(query_id, std::numeric_limits<int>::max())) {
    n.keyframes.push_back(id);
  }
  n.keyframe_set.insert(n.keyframes.begin(), n.keyframes.end());
  const Rigid3d world_from_query = map->FindKeyframe(query_id)->cam_from_world.Inverse();
  for (const Id id : n.keyframes) {
    const Rigid3d& cam_from_world = map->FindKeyframe(id)->cam_from_world;
    n.non_corrected[id] = Sim3d(cam_from_world);
    n.corrected[id] = Sim3d(cam_from_world * world_from_query) * corrected_query_cam_from_world;
  }
  // The keyframe each landmark of the neighbourhood moves with.
  for (const Id id : n.keyframes) {
    for (const Id landmark_id : map->FindKeyframe(id)->landmark_ids) {
      const SlamLandmark* landmark = map->FindLandmark(landmark_id);
      if (landmark == nullptr || n.corrected_by.count(landmark_id)) continue;
      n.corrected_by[landmark_id] = n.keyframe_set.count(landmark->reference_keyframe_id)
                                        ? landmark->reference_keyframe_id
                                        : id;
    }
  }
  for (const auto& [landmark_id, kf_id] : n.corrected_by) {
    SlamLandmark* landmark = map->FindLandmark(landmark_id);
    landmark->position_in_world =
        n.corrected.at(kf_id).Inverse() * (n.non_corrected.at(kf_id) * landmark->position_in_world);
  }
  for (const Id id : n.keyframes) {
    map->FindKeyframe(id)->cam_from_world = ToRigid(n.corrected.at(id));
  }
  for (const auto& [landmark_id, kf_id] : n.corrected_by) map->UpdateLandmarkGeometry(landmark_id);
  return n;
}

std::map<Id, std::set<Id>> CovisibleSets(const std::vector<Id>& keyframes, const SlamMap& map) {
  std::map<Id, std::set<Id>> sets;
  for (const Id id : keyframes) {
    const SlamKeyframe* kf = map.FindKeyframe(id);
    if (kf == nullptr) continue;
    for (const auto& [other, weight] : kf->ordered_covisibles) sets[id].insert(other);
  }
  return sets;
}

std::map<Id, std::vector<Id>> NewLoopConnections(const NeighbourhoodCorrection& n,
                                                 const std::map<Id, std::set<Id>>& before,
                                                 SlamMap* map) {
  for (const Id id : n.keyframes) map->UpdateCovisibility(id);
  std::map<Id, std::vector<Id>> connections;
  static const std::set<Id> kNone;
  for (const Id id : n.keyframes) {
    auto it = before.find(id);
    const std::set<Id>& previous = it == before.end() ? kNone : it->second;
    for (const auto& [other, weight] : map->FindKeyframe(id)->ordered_covisibles) {
      if (previous.count(other) || n.keyframe_set.count(other)) continue;
      connections[id].push_back(other);
    }
  }
  return connections;
}

void RelaxEssentialGraph(const NeighbourhoodCorrection& n,
                         const std::map<Id, std::vector<Id>>& loop_connections,
                         const std::vector<std::pair<Id, Id>>& loop_pairs,
                         const std::set<Id>& fixed, int segment,
                         const LoopCloserOptions& options, SlamMap* map,
                         LoopCorrectionReport* report) {
  std::vector<PoseGraphVertex> vertices;
  std::map<Id, int> vertex_of;
  std::map<Id, Sim3d> initial;
  for (const auto& [id, kf] : map->keyframes()) {
    if (kf.segment != segment) continue;
    PoseGraphVertex v;
    v.id = id;
    auto it = n.corrected.find(id);
    v.cam_from_world = it != n.corrected.end() ? it->second : Sim3d(kf.cam_from_world);
    v.fixed = fixed.count(id) > 0;
    initial[id] = v.cam_from_world;
    vertex_of[id] = static_cast<int>(vertices.size());
    vertices.push_back(v);
  }
  auto before = [&](Id id) -> const Sim3d& {
    auto it = n.non_corrected.find(id);
    return it != n.non_corrected.end() ? it->second : initial.at(id);
  };
  const std::set<std::pair<Id, Id>> pair_set = [&] {
    std::set<std::pair<Id, Id>> out;
    for (const auto& [a, b] : loop_pairs) out.insert(Ordered(a, b));
    return out;
  }();
  std::vector<PoseGraphEdge> edges;
  std::set<std::pair<Id, Id>> inserted;
  auto add_edge = [&](Id from, Id to, const Sim3d& to_from_from) {
    PoseGraphEdge e;
    e.from = vertex_of.at(from);
    e.to = vertex_of.at(to);
    e.to_from_from = to_from_from;
    edges.push_back(e);
    inserted.insert(Ordered(from, to));
  };
  for (const auto& [id, others] : loop_connections) {
    const SlamKeyframe& kf = map->keyframes().at(id);
    for (const Id other : others) {
      if (!vertex_of.count(id) || !vertex_of.count(other)) continue;
      auto w = kf.covisibility_weights.find(other);
      const int weight = w == kf.covisibility_weights.end() ? 0 : w->second;
      if (!pair_set.count(Ordered(id, other)) && weight < options.min_essential_covisibility) {
        continue;
      }
      if (inserted.count(Ordered(id, other))) continue;
      add_edge(id, other, initial.at(other) * initial.at(id).Inverse());
    }
  }
  for (const auto& [a, b] : loop_pairs) {
    if (!vertex_of.count(a) || !vertex_of.count(b) || inserted.count(Ordered(a, b))) continue;
    add_edge(a, b, initial.at(b) * initial.at(a).Inverse());
  }
  for (const auto& [id, kf] : map->keyframes()) {
    if (!vertex_of.count(id)) continue;
    const Sim3d world_from_i = before(id).Inverse();
    if (kf.parent_id != kInvalidId && vertex_of.count(kf.parent_id) &&
        !inserted.count(Ordered(id, kf.parent_id))) {
      add_edge(id, kf.parent_id, before(kf.parent_id) * world_from_i);
    }
    for (const auto& [a, b] : map->loop_edges()) {
      const Id other = a == id ? b : (b == id ? a : kInvalidId);
      if (other == kInvalidId || other >= id || !vertex_of.count(other)) continue;
      if (inserted.count(Ordered(id, other))) continue;
      add_edge(id, other, before(other) * world_from_i);
    }
    for (const auto& [other, weight] : kf.ordered_covisibles) {
      if (weight < options.min_essential_covisibility) break;  // sorted by decreasing weight
      if (other >= id || other == kf.parent_id || !vertex_of.count(other)) continue;
      if (std::find(kf.child_ids.begin(), kf.child_ids.end(), other) != kf.child_ids.end()) {
        continue;
      }
      if (inserted.count(Ordered(id, other))) continue;
      add_edge(id, other, before(other) * world_from_i);
    }
  }
  report->num_edges = static_cast<int>(edges.size());
  report->pose_graph = OptimizePoseGraph(options.pose_graph, edges, &vertices);

  // 4. Write back poses and move every landmark with its keyframe.
  if (report->pose_graph.success) {
    // A vertex started at scale 1 (or the loop's, for the neighbourhood, whose landmarks step 1
    // already moved): the map around it now has 1 / its scale times its original size.
    for (const PoseGraphVertex& v : vertices) {
      SlamKeyframe* kf = map->FindKeyframe(v.id);
      kf->cam_from_world = ToRigid(v.cam_from_world);
      kf->scale /= v.cam_from_world.scale;
    }
    for (auto& [landmark_id, landmark] : map->mutable_landmarks()) {
      auto by = n.corrected_by.find(landmark_id);
      Id anchor = by != n.corrected_by.end() ? by->second : landmark.reference_keyframe_id;
      if (!vertex_of.count(anchor)) {
        anchor = landmark.observations.empty() ? kInvalidId
                                               : landmark.observations.front().keyframe_id;
      }
      if (!vertex_of.count(anchor)) continue;
      const Sim3d& optimized = vertices[vertex_of.at(anchor)].cam_from_world;
      landmark.position_in_world =
          optimized.Inverse() * (initial.at(anchor) * landmark.position_in_world);
    }
  } else {
    for (const Id id : n.keyframes) map->FindKeyframe(id)->scale /= n.corrected.at(id).scale;
  }
  for (const auto& [landmark_id, landmark] : map->landmarks()) {
    map->UpdateLandmarkGeometry(landmark_id);
  }
}

LoopCorrectionReport CorrectLoop(const LoopDetection& loop, const LoopCloserOptions& options,
                                 SlamMap* map) {
  const auto start = std::chrono::steady_clock::now();
  LoopCorrectionReport report;
  const Id query_id = loop.query_keyframe_id;
  const Id match_id = loop.match_keyframe_id;
  if (map->FindKeyframe(query_id) == nullptr || map->FindKeyframe(match_id) == nullptr ||
      query_id == match_id) {
    return report;
  }

  const int segment = map->FindKeyframe(match_id)->segment;
  const std::map<Id, Rigid3d> loaded_poses =
      options.keep_loaded_datum ? LoadedPoses(*map, segment) : std::map<Id, Rigid3d>();

  // 1. Correct the query's neighbourhood.
  const NeighbourhoodCorrection n =
      CorrectNeighbourhood(query_id, loop.corrected_query_cam_from_world, map);
  report.num_keyframes_corrected = static_cast<int>(n.keyframes.size());

  // 2. Fusion: the loop matches into the query, then the match side's landmarks into the
  // corrected neighbourhood.
  for (const auto& [index, landmark_id] : loop.matches) {
    if (index < 0 || index >= static_cast<int>(map->FindKeyframe(query_id)->keypoints.size())) {
      continue;
    }
    report.num_fused += FuseAt(query_id, index, landmark_id, map);
  }
  std::vector<Id> loop_landmarks;
  {
    std::set<Id> listed;
    std::vector<Id> match_group{match_id};
    for (const Id id : map->CovisibleKeyframes(match_id, std::numeric_limits<int>::max())) {
      match_group.push_back(id);
    }
    for (const Id kf_id : match_group) {
      for (const Id landmark_id : map->FindKeyframe(kf_id)->landmark_ids) {
        if (landmark_id != kInvalidId && listed.insert(landmark_id).second) {
          loop_landmarks.push_back(landmark_id);
        }
      }
    }
  }
  KeyframeProjectionOptions fuse_options;
  fuse_options.radius_factor = options.fuse_radius_factor;
  for (const Id id : n.keyframes) {
    const SlamKeyframe* kf = map->FindKeyframe(id);
    if (kf == nullptr) continue;
    const std::vector<KeyframeProjectionMatch> matches =
        MatchLandmarksIntoKeyframe(*map, *kf, n.corrected.at(id), loop_landmarks, fuse_options);
    for (const KeyframeProjectionMatch& m : matches) {
      report.num_fused += FuseAt(id, m.keypoint_index, m.landmark_id, map);
    }
  }
  // New covisibility links created by the fusion (ORB-SLAM's LoopConnections): the fusion
  // changed observations but not yet the covisibility graph.
  const std::map<Id, std::vector<Id>> loop_connections =
      NewLoopConnections(n, CovisibleSets(n.keyframes, *map), map);

  // 3-4. Essential graph over the loop's segment (query and match share it: System merges
  // segments first), the match fixed.
  RelaxEssentialGraph(n, loop_connections, {{query_id, match_id}}, {match_id}, segment, options,
                      map, &report);
  if (!loaded_poses.empty()) RestoreLoadedDatum(loaded_poses, segment, map);
  map->AddLoopEdge(query_id, match_id);
  report.success = true;
  report.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace lcv::slam
