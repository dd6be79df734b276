#include "slam/module/line_cloud_relocalizer.h"

#include <algorithm>
#include <chrono>
#include <map>
#include <set>
#include <vector>

namespace lcv::slam {

void BuildServerKeyframeBow(const Vocabulary& vocabulary, SlamMap* map,
                            BowDatabase* server_database) {
  server_database->Clear();
  if (vocabulary.empty()) return;
  std::vector<OrbDescriptor> descriptors;
  for (auto& [id, kf] : map->mutable_server_keyframes()) {
    descriptors.clear();
    kf.descriptor_line_ids.clear();
    for (const Id line_id : kf.line_ids) {
      const SlamLine* line = map->FindLine(line_id);
      if (line == nullptr || !line->descriptor) continue;
      descriptors.push_back(*line->descriptor);
      kf.descriptor_line_ids.push_back(line_id);
    }
    vocabulary.Transform(descriptors, &kf.bow, &kf.direct_index, kDirectIndexLevel);
    if (!kf.bow.empty()) server_database->Add(id, kf.bow);
  }
}

std::vector<Id> SelectServerCandidates(const SlamMap& map,
                                       const std::vector<BowQueryResult>& results,
                                       const std::vector<OrbDescriptor>& query_descriptors,
                                       const LineCloudRelocalizerOptions& options) {
  std::vector<Id> pool;
  const int pool_size = std::max(options.max_candidates, options.vote_pool);
  for (const BowQueryResult& r : results) {
    if (static_cast<int>(pool.size()) >= pool_size) break;
    pool.push_back(r.keyframe_id);
  }
  if (options.vote_pool <= 0 || query_descriptors.empty() ||
      static_cast<int>(pool.size()) <= options.max_candidates) {
    pool.resize(std::min<std::size_t>(pool.size(), std::max(options.max_candidates, 0)));
    return pool;
  }
  // The pool's lines, each with the pool keyframes that see it.
  std::map<Id, std::vector<int>> viewers_of_line;
  for (int k = 0; k < static_cast<int>(pool.size()); ++k) {
    const SlamServerKeyframe* kf = map.FindServerKeyframe(pool[k]);
    if (kf == nullptr) continue;
    for (const Id line_id : kf->line_ids) viewers_of_line[line_id].push_back(k);
  }
  std::vector<const OrbDescriptor*> descriptors;
  std::vector<const std::vector<int>*> viewers;
  for (const auto& [line_id, keyframes] : viewers_of_line) {
    const SlamLine* line = map.FindLine(line_id);
    if (line == nullptr || !line->descriptor) continue;
    descriptors.push_back(&*line->descriptor);
    viewers.push_back(&keyframes);
  }
  // Each query descriptor votes for the pool keyframes seeing its nearest line, when that line
  // is within vote_max_hamming_distance. No ratio test: in a repetitive scene the true line's
  // look-alikes fail it, while their votes spread over the whole pool and the true place's
  // stand out together.
  std::vector<int> votes(pool.size(), 0);
  for (const OrbDescriptor& query : query_descriptors) {
    int best = options.vote_max_hamming_distance + 1, best_line = -1;
    for (int l = 0; l < static_cast<int>(descriptors.size()); ++l) {
      const int d = HammingDistance(query, *descriptors[l]);
      if (d < best) {
        best = d;
        best_line = l;
      }
    }
    if (best_line < 0) continue;
    for (const int k : *viewers[best_line]) ++votes[k];
  }
  std::vector<int> order(pool.size());
  for (int k = 0; k < static_cast<int>(pool.size()); ++k) order[k] = k;
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return votes[a] > votes[b]; });  // ties: BoW order
  std::vector<Id> candidates;
  for (int i = 0; i < options.max_candidates; ++i) candidates.push_back(pool[order[i]]);
  return candidates;
}

namespace {

// The candidates' lines with descriptors, and the X' of another registered segment on them.
void CollectLines(const SlamMap& map, const std::vector<Id>& candidates,
                  bool restored_of_active_segment, std::vector<RegistrationLine>* lines,
                  std::vector<RegistrationServerPoint>* server_points) {
  std::set<Id> line_ids;
  for (const Id id : candidates) {
    const SlamServerKeyframe* kf = map.FindServerKeyframe(id);
    if (kf != nullptr) line_ids.insert(kf->line_ids.begin(), kf->line_ids.end());
  }
  const int registered = map.registered_segment();
  for (const Id id : line_ids) {
    const SlamLine* line = map.FindLine(id);
    if (line == nullptr || !line->descriptor) continue;
    RegistrationLine out;
    out.line_id = id;
    out.line = line->line;
    out.information = line->information;
    out.descriptor = *line->descriptor;
    lines->push_back(out);
    const SlamLandmark* restored = map.FindLandmark(line->restored_landmark_id);
    if (restored != nullptr && registered >= 0 && restored->segment == registered &&
        (restored_of_active_segment || registered != map.active_segment())) {
      RegistrationServerPoint point;
      point.id = restored->id;
      point.position = restored->position_in_world;
      point.descriptor = restored->descriptor;
      server_points->push_back(point);
    }
  }
}

}  // namespace

LineCloudRelocalizationReport MatchKeyframeToLineCloud(
    const Vocabulary* vocabulary, const BowDatabase& server_database, Id keyframe_id,
    const LineCloudRelocalizerOptions& options, const LineCloudMatchScope& scope,
    std::uint64_t seed, const SlamMap& map_ref) {
  const SlamMap* map = &map_ref;
  const auto start = std::chrono::steady_clock::now();
  LineCloudRelocalizationReport report;
  report.keyframe_id = keyframe_id;
  auto finish = [&](std::string failure) {
    report.failure = std::move(failure);
    report.time_ms = std::chrono::duration<double, std::milli>(
                         std::chrono::steady_clock::now() - start).count();
    return report;
  };
  const SlamKeyframe* keyframe = map->FindKeyframe(keyframe_id);
  if (keyframe == nullptr) return finish("keyframe " + std::to_string(keyframe_id) + " erased");

  std::vector<Id> candidates;
  if (vocabulary != nullptr && !vocabulary->empty() && server_database.size() > 0) {
    // The keyframe's landmarks' descriptors: the BoW query (query_from_landmarks) and the votes.
    std::vector<OrbDescriptor> landmark_descriptors;
    for (const Id id : keyframe->landmark_ids) {
      const SlamLandmark* landmark = map->FindLandmark(id);
      if (landmark != nullptr) landmark_descriptors.push_back(landmark->descriptor);
    }
    BowVector landmark_bow;
    if (options.query_from_landmarks) vocabulary->Transform(landmark_descriptors, &landmark_bow);
    const BowVector& query = options.query_from_landmarks && !landmark_bow.empty()
                                 ? landmark_bow
                                 : keyframe->bow.get();
    const std::vector<Id> excluded(scope.excluded.begin(), scope.excluded.end());
    candidates = SelectServerCandidates(*map, server_database.Query(query, 0, excluded),
                                        landmark_descriptors, options);
  } else {
    for (const auto& [id, kf] : map->server_keyframes()) {
      if (!scope.excluded.count(id)) candidates.push_back(id);
    }
  }
  report.num_candidates = static_cast<int>(candidates.size());
  if (candidates.empty()) return finish("no server keyframe shares a visual word");

  std::vector<RegistrationLine> lines;
  std::vector<RegistrationServerPoint> server_points;
  CollectLines(*map, candidates, scope.restored_of_active_segment, &lines, &server_points);
  report.num_lines = static_cast<int>(lines.size());

  // The keyframe and its best covisible keyframes: the views of the rigid-stereo BA.
  std::vector<RegistrationView> views;
  std::map<Id, int> view_of_keyframe;
  std::vector<Id> view_ids{keyframe_id};
  for (const Id id : map->CovisibleKeyframes(keyframe_id, options.max_views - 1)) {
    view_ids.push_back(id);
  }
  report.view_keyframe_ids = view_ids;
  for (const Id id : view_ids) {
    const SlamKeyframe* kf = map->FindKeyframe(id);
    RegistrationView view;
    view.keyframe_id = id;
    view.cam_from_world = kf->cam_from_world;
    view.camera = kf->camera;
    view_of_keyframe[id] = static_cast<int>(views.size());
    views.push_back(view);
  }
  // X_ckf: the keyframe's points, observed in the views.
  std::vector<RegistrationPoint> points;
  std::set<Id> seen;
  std::vector<Id> point_ids = keyframe->landmark_ids;
  if (scope.points_of_all_views) {
    for (size_t v = 1; v < view_ids.size(); ++v) {
      const std::vector<Id>& more = map->FindKeyframe(view_ids[v])->landmark_ids;
      point_ids.insert(point_ids.end(), more.begin(), more.end());
    }
  }
  for (const Id id : point_ids) {
    if (id == kInvalidId || !seen.insert(id).second) continue;
    const SlamLandmark* landmark = map->FindLandmark(id);
    if (landmark == nullptr || landmark->IsRestored()) continue;
    RegistrationPoint point;
    point.landmark_id = id;
    point.position = landmark->position_in_world;
    point.descriptor = landmark->descriptor;
    for (const Observation& o : landmark->observations) {
      auto view = view_of_keyframe.find(o.keyframe_id);
      if (view == view_of_keyframe.end()) continue;
      const SlamKeyframe& kf = *map->FindKeyframe(o.keyframe_id);
      const Keypoint& kp = kf.keypoints[o.keypoint_index];
      RegistrationObservation obs;
      obs.view = view->second;
      obs.observed_px = Eigen::Vector2d(kp.x, kp.y);
      obs.information = kf.scale_levels.InverseSigma2(kp.octave);
      point.observations.push_back(obs);
    }
    points.push_back(std::move(point));
  }

  LineCloudRegistrationOptions registration_options = options.registration;
  registration_options.random_seed = seed;
  report.registration =
      RegisterToLineCloud(views, points, lines, server_points, registration_options);
  if (!report.registration.success) return finish(report.registration.failure);
  report.success = true;
  return finish("");
}

void ApplyLineCloudRegistration(const LineCloudRegistration& registration,
                                const std::vector<Id>& view_ids, SlamMap* map) {
  // Apply: the segment into the server frame, inliers restored on their lines.
  const int active = map->active_segment();
  map->MoveSegment(active, active, registration.server_from_client);
  for (const LineCloudRegistration::RestoredPoint& r : registration.restored) {
    SlamLandmark* landmark = map->FindLandmark(r.landmark_id);
    const SlamLine* line = map->FindLine(r.line_id);
    if (landmark == nullptr || line == nullptr || landmark->IsRestored() ||
        line->restored_landmark_id != kInvalidId) {
      continue;
    }
    landmark->position_in_world = r.position_in_server;
    map->RestoreOnLine(r.landmark_id, r.line_id);
  }
  // A segment registered before (the client was lost and started over) is in the same frame
  // now: join them, and fuse the points matched to its X'.
  const int registered = map->registered_segment();
  if (registered >= 0 && registered != active) {
    map->MoveSegment(active, registered, Sim3d());
    for (const auto& [landmark_id, server_point_id] : registration.point_matches) {
      if (map->FindLandmark(landmark_id) && map->FindLandmark(server_point_id)) {
        map->ReplaceLandmark(landmark_id, server_point_id);
      }
    }
  } else {
    map->SetRegisteredSegment(active);
  }
  std::vector<Id> landmark_ids;
  for (const auto& [id, landmark] : map->landmarks()) {
    if (landmark.segment == map->active_segment()) landmark_ids.push_back(id);
  }
  for (const Id id : landmark_ids) map->UpdateLandmarkGeometry(id);
  for (const Id id : view_ids) {
    if (map->FindKeyframe(id) != nullptr) map->UpdateCovisibility(id);
  }
}

LineCloudRelocalizationReport RelocalizeInLineCloud(const Vocabulary* vocabulary,
                                                    const BowDatabase& server_database,
                                                    Id keyframe_id,
                                                    const LineCloudRelocalizerOptions& options,
                                                    std::uint64_t seed, SlamMap* map) {
  const auto start = std::chrono::steady_clock::now();
  LineCloudRelocalizationReport report = MatchKeyframeToLineCloud(
      vocabulary, server_database, keyframe_id, options, LineCloudMatchScope(), seed, *map);
  if (!report.success) return report;
  ApplyLineCloudRegistration(report.registration, report.view_keyframe_ids, map);
  report.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace lcv::slam
