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

}  // namespace

const SnapshotLandmark* LocalMapSnapshot::FindLandmark(Id id) const {
  return FindById(landmarks, id);
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
  snapshot.reference_num_tracked = reference->NumLandmarksWithObservations(
      map, snapshot.map_num_keyframes <= 2 ? 2 : 3);

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
    snapshot.landmarks.push_back(out);
  }
  snapshot.all_keyframes.reserve(map.keyframes().size());
  for (const auto& [id, kf] : map.keyframes()) {
    snapshot.all_keyframes.push_back({kf.id, kf.timestamp, kf.cam_from_world, kf.scale});
  }
  return snapshot;
}

}  // namespace lcv::slam
