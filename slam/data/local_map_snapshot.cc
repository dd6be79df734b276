#include "slam/data/local_map_snapshot.h"

#include <algorithm>
#include <set>

#include "slam/util/error.h"

namespace lcv::slam {
namespace {

template <typename T>
const T* FindById(const std::vector<T>& sorted, Id id) {
  auto it = std::lower_bound(sorted.begin(), sorted.end(), id,
                             [](const T& e, Id value) { return e.id < value; });
  return it != sorted.end() && it->id == id ? &*it : nullptr;
}

// The lines of the server keyframes nearest to the reference keyframe, or to options.lines_near
// (none while the client is detached from the line cloud), and of the window's X'.
void AddNearbyLines(const SlamMap& map, const SlamKeyframe& reference,
                    const LocalMapSnapshotOptions& options, LocalMapSnapshot* snapshot) {
  std::set<Id> line_ids;
  if (!map.LineCloudDetached()) {
    std::vector<std::pair<double, Id>> by_distance;
    by_distance.reserve(map.server_keyframes().size());
    const Eigen::Vector3d center = options.lines_near.value_or(reference.Center());
    for (const auto& [id, kf] : map.server_keyframes()) {
      by_distance.emplace_back((kf.cam_from_world.Center() - center).squaredNorm(), id);
    }
    const size_t count = std::min<size_t>(by_distance.size(), options.max_server_keyframes);
    std::partial_sort(by_distance.begin(), by_distance.begin() + count, by_distance.end());
    for (size_t k = 0; k < count; ++k) {
      const std::vector<Id>& seen = map.FindServerKeyframe(by_distance[k].second)->line_ids;
      line_ids.insert(seen.begin(), seen.end());
    }
  }
  for (const SnapshotLandmark& landmark : snapshot->landmarks) {
    if (landmark.line_id != kInvalidId) line_ids.insert(landmark.line_id);
  }
  snapshot->lines.reserve(line_ids.size());
  for (const Id id : line_ids) {
    const SlamLine* line = map.FindLine(id);
    if (line == nullptr) continue;
    SnapshotLine out;
    out.id = id;
    out.line = line->line;
    out.sqrt_information = line->sqrt_information;
    out.has_descriptor = line->descriptor.has_value();
    if (line->descriptor) out.descriptor = *line->descriptor;
    out.has_interval = line->has_interval;
    out.s_min = line->s_min;
    out.s_max = line->s_max;
    out.restored_landmark_id = line->restored_landmark_id;
    int num_viewers = 0;
    for (const Id kf_id : line->server_keyframe_ids) {
      const SlamServerKeyframe* kf = map.FindServerKeyframe(kf_id);
      if (kf == nullptr) continue;
      out.viewers_centroid += kf->cam_from_world.Center();
      ++num_viewers;
    }
    out.has_viewers = num_viewers > 0;
    if (out.has_viewers) out.viewers_centroid /= num_viewers;
    snapshot->lines.push_back(out);
  }
}

}  // namespace

const SnapshotLine* LocalMapSnapshot::FindLine(Id id) const { return FindById(lines, id); }
const SnapshotLandmark* LocalMapSnapshot::FindLandmark(Id id) const {
  if (landmark_ids.size() != landmarks.size()) return FindById(landmarks, id);
  const auto it = std::lower_bound(landmark_ids.begin(), landmark_ids.end(), id);
  return it != landmark_ids.end() && *it == id ? &landmarks[it - landmark_ids.begin()] : nullptr;
}
const SnapshotKeyframe* LocalMapSnapshot::FindKeyframe(Id id) const {
  return FindById(all_keyframes, id);
}

LocalMapSnapshot MakeLocalMapSnapshot(const SlamMap& map, Id reference_keyframe_id,
                                      const LocalMapSnapshotOptions& options,
                                      std::uint64_t version) {
  const SlamKeyframe* reference = map.FindKeyframe(reference_keyframe_id);
  LCV_CHECK(reference != nullptr) << "keyframe " << reference_keyframe_id;
  LocalMapSnapshot snapshot;
  snapshot.version = version;
  snapshot.reference_keyframe_id = reference_keyframe_id;
  snapshot.map_num_keyframes = map.NumKeyframesInSegment(map.active_segment());
  snapshot.map_num_landmarks = static_cast<int>(map.landmarks().size());
  const SlamKeyframe::LandmarkCounts counts =
      reference->CountLandmarks(map, snapshot.map_num_keyframes <= 2 ? 2 : 3);
  snapshot.reference_num_tracked = counts.well_observed_points;
  snapshot.reference_num_restored = counts.restored;
  snapshot.reference_median_distance = reference->MedianLandmarkDistance(map);
  snapshot.reference_source_frame_id = reference->source_frame_id;
  snapshot.reference_landmark_ids = reference->landmark_ids;

  // Window: reference, first ring (covisibles), second ring (their best neighbours), parent.
  std::set<Id> window{reference_keyframe_id};
  const std::vector<Id> first_ring =
      map.CovisibleKeyframes(reference_keyframe_id, options.max_covisible_keyframes);
  window.insert(first_ring.begin(), first_ring.end());
  for (const Id id : first_ring) {
    if (static_cast<int>(window.size()) >= options.max_window_keyframes) break;
    for (const Id second : map.CovisibleKeyframes(id, options.max_second_ring_per_keyframe)) {
      window.insert(second);
      if (static_cast<int>(window.size()) >= options.max_window_keyframes) break;
    }
  }
  if (reference->parent_id != kInvalidId && map.FindKeyframe(reference->parent_id)) {
    window.insert(reference->parent_id);
  }

  std::set<Id> landmark_ids;
  for (const Id id : window) {
    const SlamKeyframe& kf = map.keyframes().at(id);
    snapshot.keyframes.push_back({kf.id, kf.timestamp, kf.cam_from_world, kf.scale});
    for (const Id landmark_id : kf.landmark_ids) {
      if (landmark_id != kInvalidId) landmark_ids.insert(landmark_id);
    }
  }
  snapshot.landmarks.reserve(landmark_ids.size());
  snapshot.landmark_ids.reserve(landmark_ids.size());
  for (const Id id : landmark_ids) {
    const SlamLandmark* landmark = map.FindLandmark(id);
    if (landmark == nullptr) continue;
    SnapshotLandmark out;
    out.id = id;
    out.position_in_world = landmark->position_in_world;
    out.descriptor = landmark->descriptor;
    out.mean_viewing_direction = landmark->mean_viewing_direction;
    out.min_distance = landmark->min_distance;
    out.max_distance = landmark->max_distance;
    out.num_observations = landmark->NumObservations();
    out.line_id = landmark->line_id;
    snapshot.landmarks.push_back(out);
    snapshot.landmark_ids.push_back(id);
  }
  snapshot.registered = map.ActiveSegmentRegistered() && map.HasLineCloud();
  if (snapshot.registered) AddNearbyLines(map, *reference, options, &snapshot);
  snapshot.all_keyframes.reserve(map.keyframes().size());
  for (const auto& [id, kf] : map.keyframes()) {
    snapshot.all_keyframes.push_back({kf.id, kf.timestamp, kf.cam_from_world, kf.scale});
  }
  return snapshot;
}

}  // namespace lcv::slam
