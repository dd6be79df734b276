#include "slam/module/line_cloud_loop.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <set>

namespace lcv::slam {
namespace {

// Median distance of the keyframe's points (scene scale for the drift test), 1 without points.
double MedianDepth(const SlamMap& map, const SlamKeyframe& kf) {
  const double distance = kf.MedianLandmarkDistance(map);
  return distance > 0.0 ? distance : 1.0;
}

int RestoredObservations(const SlamKeyframe& kf, const SlamMap& map) {
  int count = 0;
  for (const Id landmark_id : kf.landmark_ids) {
    const SlamLandmark* landmark = map.FindLandmark(landmark_id);
    count += landmark != nullptr && landmark->IsRestored();
  }
  return count;
}

// Whether no server keyframe's centre is within factor times the keyframe's median depth.
bool FarFromServerKeyframes(const SlamMap& map, const SlamKeyframe& kf, double factor) {
  const Eigen::Vector3d centre = kf.Center();
  const double limit = factor * MedianDepth(map, kf);
  for (const auto& [id, server] : map.server_keyframes()) {
    if ((server.cam_from_world.Center() - centre).squaredNorm() <= limit * limit) return false;
  }
  return true;
}

}  // namespace

bool UpdateLineCloudDetachment(const SlamMap& map, Id keyframe_id,
                               const LineCloudLoopOptions& options, int* low_streak) {
  const SlamKeyframe* keyframe = map.FindKeyframe(keyframe_id);
  if (options.detach_below_restored <= 0 || keyframe == nullptr ||
      !map.ActiveSegmentRegistered() || keyframe->segment != map.active_segment()) {
    *low_streak = 0;
    return false;
  }
  // Left the line cloud: the keyframe observes few X', or no server keyframe is near it (a
  // 360-degree camera keeps seeing X' of the mapped streets from the next one).
  const bool left =
      RestoredObservations(*keyframe, map) < options.detach_below_restored ||
      (options.detach_beyond_depths > 0.0 &&
       FarFromServerKeyframes(map, *keyframe, options.detach_beyond_depths));
  if (!left) {
    *low_streak = 0;
    return false;
  }
  const int needed = std::max(options.detach_after_keyframes, 1);
  if (!map.LineCloudDetached() && *low_streak >= needed) *low_streak = 0;  // attached since
  ++*low_streak;
  return *low_streak >= needed;
}

std::optional<LineCloudLoopDetection> DetectLineCloudLoop(const Vocabulary* vocabulary,
                                                          const BowDatabase& server_database,
                                                          Id query_keyframe_id,
                                                          const LineCloudLoopOptions& options,
                                                          std::uint64_t seed, const SlamMap& map) {
  const SlamKeyframe* query = map.FindKeyframe(query_keyframe_id);
  if (query == nullptr || !map.HasLineCloud() || map.server_keyframes().empty()) {
    return std::nullopt;
  }
  if (!map.ActiveSegmentRegistered() || query->segment != map.active_segment()) {
    return std::nullopt;
  }
  LineCloudMatchScope scope;
  scope.restored_of_active_segment = true;
  scope.points_of_all_views = true;
  // A registration with fewer inliers than a loop needs is no loop: asking it of the
  // registration lets its RANSAC stop sooner (RegisterToLineCloud, step 3).
  LineCloudRelocalizerOptions relocalizer = options.relocalizer;
  relocalizer.registration.min_inliers =
      std::max(relocalizer.registration.min_inliers, options.min_inliers);
  // Attached, the map is in the line cloud's frame: when it already agrees with the matches
  // there is no drift to correct, and RANSAC, which would find the identity again, is skipped.
  // Detached, the return is what is looked for and the drift gate below is off, so is this.
  if (!map.LineCloudDetached()) relocalizer.registration.prior = Sim3d();
  const LineCloudRelocalizationReport match = MatchKeyframeToLineCloud(
      vocabulary, server_database, query_keyframe_id, relocalizer, scope, seed, map);
  if (!match.success || match.registration.num_inliers < options.min_inliers) return std::nullopt;

  // The registration against the map as it is: a client that has not drifted from the line
  // cloud registers at (nearly) the identity, and there is nothing to correct.
  const Sim3d& s = match.registration.server_from_client;
  const Eigen::Vector3d center = query->cam_from_world.Center();
  const double depth = MedianDepth(map, *query);
  const double moved = (s * center - center).norm();
  const double turned_deg = s.rotation.angularDistance(Eigen::Quaterniond::Identity()) * 180.0 / M_PI;
  const double rescaled = std::abs(std::log(s.scale));
  if (!map.LineCloudDetached() && moved < options.min_drift_of_depth * depth &&
      turned_deg < options.min_drift_deg &&
      rescaled < options.min_drift_scale) {
    return std::nullopt;
  }

  LineCloudLoopDetection loop;
  loop.query_keyframe_id = query_keyframe_id;
  loop.registration = match.registration;
  loop.num_candidates = match.num_candidates;
  // x_cam = T_q * X_client = T_q * S^-1 * X_server.
  loop.corrected_query_cam_from_world =
      Sim3d(query->cam_from_world) * match.registration.server_from_client.Inverse();
  return loop;
}

LineCloudLoopCorrection CorrectLineCloudLoop(const LineCloudLoopDetection& loop,
                                             const LineCloudLoopOptions& options, SlamMap* map) {
  const auto start = std::chrono::steady_clock::now();
  LineCloudLoopCorrection out;
  const Id query_id = loop.query_keyframe_id;
  const SlamKeyframe* query = map->FindKeyframe(query_id);
  if (query == nullptr || !map->ActiveSegmentRegistered() ||
      query->segment != map->active_segment()) {
    return out;
  }
  const int segment = query->segment;

  // 1. The neighbourhood into the line cloud's frame.
  const NeighbourhoodCorrection n =
      CorrectNeighbourhood(query_id, loop.corrected_query_cam_from_world, map);
  out.report.num_keyframes_corrected = static_cast<int>(n.keyframes.size());

  // 2. Fusion with the X' restored before, and new X' on lines that had none. The
  // registration's positions are in the server frame, where step 1 put the neighbourhood.
  for (const auto& [landmark_id, restored_id] : loop.registration.point_matches) {
    const SlamLandmark* landmark = map->FindLandmark(landmark_id);
    const SlamLandmark* restored = map->FindLandmark(restored_id);
    if (landmark == nullptr || restored == nullptr || landmark_id == restored_id ||
        landmark->IsRestored() || !restored->IsRestored()) {
      continue;
    }
    map->ReplaceLandmark(landmark_id, restored_id);
    ++out.report.num_fused;
  }
  for (const LineCloudRegistration::RestoredPoint& r : loop.registration.restored) {
    SlamLandmark* landmark = map->FindLandmark(r.landmark_id);
    const SlamLine* line = map->FindLine(r.line_id);
    if (landmark == nullptr || line == nullptr || landmark->IsRestored()) continue;
    if (line->restored_landmark_id != kInvalidId) {
      // The line was restored before: the point is that X' seen again.
      if (map->FindLandmark(line->restored_landmark_id) != nullptr) {
        map->ReplaceLandmark(r.landmark_id, line->restored_landmark_id);
        ++out.report.num_fused;
      }
      continue;
    }
    landmark->position_in_world = r.position_in_server;
    map->RestoreOnLine(r.landmark_id, r.line_id);
    ++out.num_restored;
  }
  for (const auto& [id, landmark] : map->landmarks()) {
    if (landmark.segment == segment) map->UpdateLandmarkGeometry(id);
  }
  const std::map<Id, std::vector<Id>> loop_connections =
      NewLoopConnections(n, CovisibleSets(n.keyframes, *map), map);

  // 3. Essential graph: the query (placed by the line cloud just now) and the anchor, the
  // keyframe held by the line cloud on the other side of the loop, are fixed: the anchor is
  // the one the fusion made most covisible with the neighbourhood, else the keyframe with the
  // most X'. Keyframes that restored X' while drifting (a client sees the line cloud's far
  // structure from outside it) are not trusted as anchors, so the whole loop relaxes, as
  // ORB-SLAM's essential graph does between its query and match.
  std::set<Id> fixed{query_id};
  std::set<Id> anchored;
  Id most_restored = kInvalidId;
  int most_restored_count = 0;
  for (const auto& [id, kf] : map->keyframes()) {
    if (kf.segment != segment || n.keyframe_set.count(id)) continue;
    const int count = RestoredObservations(kf, *map);
    if (count < options.min_anchor_restored) continue;
    anchored.insert(id);
    if (count > most_restored_count) most_restored = id, most_restored_count = count;
  }
  Id anchor = kInvalidId;
  int anchor_weight = 0;
  for (const auto& [id, others] : loop_connections) {
    const SlamKeyframe* kf = map->FindKeyframe(id);
    for (const Id other : others) {
      if (!anchored.count(other)) continue;
      auto w = kf->covisibility_weights.find(other);
      const int weight = w == kf->covisibility_weights.end() ? 0 : w->second;
      if (weight > anchor_weight) anchor = other, anchor_weight = weight;
    }
  }
  if (anchor == kInvalidId) anchor = most_restored;
  if (anchor != kInvalidId) fixed.insert(anchor);
  if (options.hold_keyframes_made_in_line_cloud) {
    for (const Id id : anchored) {
      if (map->keyframes().at(id).made_in_line_cloud) fixed.insert(id);
    }
  }
  out.num_fixed_keyframes = static_cast<int>(fixed.size());
  std::vector<std::pair<Id, Id>> loop_pairs;
  if (anchor != kInvalidId) loop_pairs.emplace_back(query_id, anchor);
  RelaxEssentialGraph(n, loop_connections, loop_pairs, fixed, segment, options.loop_closer, map,
                      &out.report);

  // 5. X' restored while the client drifted (a line matched from a wrong pose) ended up away
  // from their lines once the drift is corrected: they were not these lines' points, and
  // global BA would drag the map back to them. They become ordinary points.
  std::vector<Id> released;
  for (const auto& [id, landmark] : map->landmarks()) {
    if (landmark.segment != segment || !landmark.IsRestored()) continue;
    const SlamLine* line = map->FindLine(landmark.line_id);
    if (line == nullptr) continue;
    const Eigen::Vector3d r = line->line.Residual(landmark.position_in_world);
    if (r.dot(line->information * r) > options.release_chi2) released.push_back(id);
  }
  for (const Id id : released) map->ReleaseFromLine(id);
  out.num_released = static_cast<int>(released.size());

  // 4. The loop edge (also what marks global BA jobs captured before as stale).
  out.anchor_keyframe_id = anchor;
  if (anchor != kInvalidId) {
    map->AddLoopEdge(query_id, anchor);
  } else {
    // No other keyframe is held by the line cloud (the segment registered at this keyframe):
    // the edge to the segment's first keyframe still records the correction.
    Id first = kInvalidId;
    for (const auto& [id, kf] : map->keyframes()) {
      if (kf.segment == segment && id != query_id) {
        first = id;
        break;
      }
    }
    if (first != kInvalidId) map->AddLoopEdge(query_id, first);
    out.anchor_keyframe_id = first;
  }
  map->SetLineCloudDetached(false);  // back in the line cloud: tracking searches its lines again
  out.report.success = true;
  out.report.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace lcv::slam
