#include "slam/data/slam_map.h"

#include <algorithm>
#include <cmath>

#include "slam/util/error.h"

namespace lcv::slam {
namespace {

bool SameCameraParams(const CameraParams& a, const CameraParams& b) {
  return a.model == b.model && a.cols == b.cols && a.rows == b.rows && a.fx == b.fx &&
         a.fy == b.fy && a.cx == b.cx && a.cy == b.cy && a.distortion == b.distortion;
}

}  // namespace


int SlamKeyframe::NumLandmarks() const {
  int count = 0;
  for (const Id id : landmark_ids) count += id != kInvalidId;
  return count;
}

double SlamKeyframe::MedianLandmarkDistance(const SlamMap& map) const {
  const Eigen::Vector3d centre = Center();
  std::vector<double> distances;
  distances.reserve(landmark_ids.size());
  for (const Id id : landmark_ids) {
    if (id == kInvalidId) continue;
    const SlamLandmark* landmark = map.FindLandmark(id);
    if (landmark != nullptr) distances.push_back((landmark->position_in_world - centre).norm());
  }
  if (distances.empty()) return 0.0;
  const auto middle = distances.begin() + distances.size() / 2;
  std::nth_element(distances.begin(), middle, distances.end());
  return *middle;
}

SlamKeyframe::LandmarkCounts SlamKeyframe::CountLandmarks(const SlamMap& map,
                                                          int min_observations) const {
  LandmarkCounts counts;
  for (const Id id : landmark_ids) {
    if (id == kInvalidId) continue;
    const SlamLandmark* landmark = map.FindLandmark(id);
    if (landmark == nullptr) continue;
    // X' are held by the server's lines; the tracked-share rule judges the client's own points.
    if (landmark->IsRestored()) {
      ++counts.restored;
    } else if (landmark->NumObservations() >= min_observations) {
      ++counts.well_observed_points;
    }
  }
  return counts;
}

SlamKeyframe& SlamMap::AddKeyframe(const Frame& frame) {
  const Id id = NewId();
  SlamKeyframe& kf = keyframes_[id];
  kf.id = id;
  kf.source_frame_id = frame.id;
  kf.timestamp = frame.timestamp;
  kf.camera = frame.camera;
  kf.scale_levels = frame.scale_levels;
  kf.cam_from_world = frame.cam_from_world;
  kf.keypoints = frame.keypoints;
  kf.descriptors = frame.descriptors;
  kf.bearings = frame.bearings;
  kf.grid = frame.grid;
  kf.bow = frame.bow;
  kf.direct_index = frame.direct_index;
  kf.landmark_ids.assign(frame.keypoints.size(), kInvalidId);
  kf.segment = active_segment_;
  if (first_keyframe_id_ == kInvalidId) first_keyframe_id_ = id;
  return kf;
}

SlamLandmark& SlamMap::AddLandmark(const Eigen::Vector3d& position_in_world, Id first_keyframe_id) {
  LCV_CHECK(keyframes_.count(first_keyframe_id)) << "keyframe " << first_keyframe_id;
  const Id id = NewId();
  SlamLandmark& landmark = landmarks_[id];
  landmark.id = id;
  landmark.position_in_world = position_in_world;
  landmark.first_keyframe_id = first_keyframe_id;
  landmark.reference_keyframe_id = first_keyframe_id;
  landmark.segment = keyframes_.at(first_keyframe_id).segment;
  return landmark;
}

bool SlamMap::IdInUse(Id id) const {
  return keyframes_.count(id) || landmarks_.count(id) || lines_.count(id) ||
         server_keyframes_.count(id);
}

SlamKeyframe& SlamMap::AddKeyframeWithId(Id id) {
  LCV_CHECK(id != kInvalidId && !IdInUse(id)) << "id " << id;
  SlamKeyframe& kf = keyframes_[id];
  kf.id = id;
  kf.segment = active_segment_;
  if (first_keyframe_id_ == kInvalidId || id < first_keyframe_id_) first_keyframe_id_ = id;
  ReserveIdsBelow(id + 1);
  return kf;
}

SlamLandmark& SlamMap::AddLandmarkWithId(Id id, const Eigen::Vector3d& position_in_world,
                                         Id first_keyframe_id) {
  LCV_CHECK(id != kInvalidId && !IdInUse(id)) << "id " << id;
  LCV_CHECK(keyframes_.count(first_keyframe_id)) << "keyframe " << first_keyframe_id;
  SlamLandmark& landmark = landmarks_[id];
  landmark.id = id;
  landmark.position_in_world = position_in_world;
  landmark.first_keyframe_id = first_keyframe_id;
  landmark.reference_keyframe_id = first_keyframe_id;
  landmark.segment = keyframes_.at(first_keyframe_id).segment;
  ReserveIdsBelow(id + 1);
  return landmark;
}

void SlamMap::ReserveIdsBelow(Id next_free_id) { next_id_ = std::max(next_id_, next_free_id); }

SlamLine& SlamMap::AddLineWithId(Id id) {
  LCV_CHECK(id != kInvalidId && !IdInUse(id)) << "id " << id;
  SlamLine& line = lines_[id];
  line.id = id;
  ReserveIdsBelow(id + 1);
  return line;
}

SlamServerKeyframe& SlamMap::AddServerKeyframeWithId(Id id) {
  LCV_CHECK(id != kInvalidId && !IdInUse(id)) << "id " << id;
  SlamServerKeyframe& kf = server_keyframes_[id];
  kf.id = id;
  ReserveIdsBelow(id + 1);
  return kf;
}

const SlamLine* SlamMap::FindLine(Id id) const {
  auto it = lines_.find(id);
  return it == lines_.end() ? nullptr : &it->second;
}
SlamLine* SlamMap::FindLine(Id id) {
  auto it = lines_.find(id);
  return it == lines_.end() ? nullptr : &it->second;
}
const SlamServerKeyframe* SlamMap::FindServerKeyframe(Id id) const {
  auto it = server_keyframes_.find(id);
  return it == server_keyframes_.end() ? nullptr : &it->second;
}

void SlamMap::ClearClientData() {
  keyframes_.clear();
  landmarks_.clear();
  erased_keyframes_.clear();
  loop_edges_.clear();
  first_keyframe_id_ = kInvalidId;
  active_segment_ = 0;
  num_segments_ = 1;
  registered_segment_ = -1;
  segments_in_line_cloud_frame_.clear();
  line_cloud_detached_ = false;
  for (auto& [id, line] : lines_) line.restored_landmark_id = kInvalidId;
}

void SlamLine::MoveTo(const Line3d& moved) {
  information = TurnLineInformation(information, line.direction, moved.direction);
  sqrt_information = SqrtInformation(information);
  line = moved;
}

void SlamMap::RestoreOnLine(Id landmark_id, Id line_id) {
  SlamLandmark* landmark = FindLandmark(landmark_id);
  SlamLine* line = FindLine(line_id);
  LCV_CHECK(landmark && line) << "landmark " << landmark_id << ", line " << line_id;
  LCV_CHECK(landmark->line_id == kInvalidId || landmark->line_id == line_id)
      << "landmark " << landmark_id << " is restored on line " << landmark->line_id;
  LCV_CHECK(line->restored_landmark_id == kInvalidId || line->restored_landmark_id == landmark_id)
      << "line " << line_id << " has X' " << line->restored_landmark_id;
  landmark->line_id = line_id;
  line->restored_landmark_id = landmark_id;
}

void SlamMap::ReleaseFromLine(Id landmark_id) {
  SlamLandmark* landmark = FindLandmark(landmark_id);
  if (landmark == nullptr) return;
  UnlinkRestored(*landmark);
  landmark->line_id = kInvalidId;
}

void SlamMap::UnlinkRestored(const SlamLandmark& landmark) {
  if (landmark.line_id == kInvalidId) return;
  SlamLine* line = FindLine(landmark.line_id);
  if (line != nullptr && line->restored_landmark_id == landmark.id) {
    line->restored_landmark_id = kInvalidId;
  }
}

bool SlamMap::AddObservation(Id landmark_id, Id keyframe_id, int keypoint_index) {
  SlamLandmark* landmark = FindLandmark(landmark_id);
  SlamKeyframe* kf = FindKeyframe(keyframe_id);
  LCV_CHECK(landmark && kf) << "landmark " << landmark_id << ", keyframe " << keyframe_id;
  LCV_CHECK(keypoint_index >= 0 && keypoint_index < static_cast<int>(kf->keypoints.size()));
  for (const Observation& o : landmark->observations) {
    if (o.keyframe_id == keyframe_id) return false;
  }
  const Id previous = kf->landmark_ids[keypoint_index];
  if (previous != kInvalidId && previous != landmark_id) {
    RemoveObservation(previous, keyframe_id, 0);
  }
  kf->landmark_ids[keypoint_index] = landmark_id;
  landmark->observations.push_back({keyframe_id, static_cast<std::uint32_t>(keypoint_index)});
  return true;
}

void SlamMap::RemoveObservation(Id landmark_id, Id keyframe_id, int min_remaining_observations) {
  SlamLandmark* landmark = FindLandmark(landmark_id);
  if (landmark == nullptr) return;
  auto& obs = landmark->observations;
  for (size_t k = 0; k < obs.size(); ++k) {
    if (obs[k].keyframe_id != keyframe_id) continue;
    SlamKeyframe* kf = FindKeyframe(keyframe_id);
    if (kf != nullptr && kf->landmark_ids[obs[k].keypoint_index] == landmark_id) {
      kf->landmark_ids[obs[k].keypoint_index] = kInvalidId;
    }
    obs.erase(obs.begin() + k);
    break;
  }
  if (static_cast<int>(obs.size()) < min_remaining_observations) {
    EraseLandmark(landmark_id);
    return;
  }
  if (landmark->reference_keyframe_id == keyframe_id) {
    landmark->reference_keyframe_id = obs.empty() ? kInvalidId : obs.front().keyframe_id;
  }
}

void SlamMap::EraseLandmark(Id landmark_id) {
  auto it = landmarks_.find(landmark_id);
  if (it == landmarks_.end()) return;
  UnlinkRestored(it->second);
  for (const Observation& o : it->second.observations) {
    SlamKeyframe* kf = FindKeyframe(o.keyframe_id);
    if (kf != nullptr && kf->landmark_ids[o.keypoint_index] == landmark_id) {
      kf->landmark_ids[o.keypoint_index] = kInvalidId;
    }
  }
  landmarks_.erase(it);
}

void SlamMap::ReplaceLandmark(Id from, Id into) {
  if (from == into) return;
  SlamLandmark* source = FindLandmark(from);
  SlamLandmark* target = FindLandmark(into);
  if (source == nullptr || target == nullptr) return;
  for (const Observation& o : source->observations) {
    SlamKeyframe* kf = FindKeyframe(o.keyframe_id);
    if (kf == nullptr) continue;
    bool seen = false;
    for (const Observation& t : target->observations) seen |= t.keyframe_id == o.keyframe_id;
    if (seen) {
      if (kf->landmark_ids[o.keypoint_index] == from) kf->landmark_ids[o.keypoint_index] = kInvalidId;
    } else {
      kf->landmark_ids[o.keypoint_index] = into;
      target->observations.push_back(o);
    }
  }
  // The line of an X' stays restored: by the landmark it is fused into when that one is free.
  const Id line_id = source->line_id;
  UnlinkRestored(*source);
  landmarks_.erase(from);
  if (line_id != kInvalidId && target->line_id == kInvalidId) {
    SlamLine* line = FindLine(line_id);
    if (line != nullptr && line->restored_landmark_id == kInvalidId) RestoreOnLine(into, line_id);
  }
  UpdateLandmarkGeometry(into);
}

bool SlamMap::HasLoopEdge(Id keyframe_id) const {
  for (const auto& [a, b] : loop_edges_) {
    if (a == keyframe_id || b == keyframe_id) return true;
  }
  return false;
}

void SlamMap::EraseKeyframe(Id keyframe_id) {
  LCV_CHECK(keyframe_id != first_keyframe_id_) << "the first keyframe anchors the gauge";
  LCV_CHECK(!HasLoopEdge(keyframe_id)) << "keyframe " << keyframe_id << " has a loop edge";
  SlamKeyframe* kf = FindKeyframe(keyframe_id);
  if (kf == nullptr) return;
  for (size_t i = 0; i < kf->landmark_ids.size(); ++i) {
    const Id landmark_id = kf->landmark_ids[i];
    if (landmark_id != kInvalidId) RemoveObservation(landmark_id, keyframe_id, 2);
  }
  for (const auto& [neighbour_id, weight] : kf->covisibility_weights) {
    SlamKeyframe* neighbour = FindKeyframe(neighbour_id);
    if (neighbour == nullptr) continue;
    neighbour->covisibility_weights.erase(keyframe_id);
    auto& ordered = neighbour->ordered_covisibles;
    ordered.erase(std::remove_if(ordered.begin(), ordered.end(),
                                 [&](const auto& e) { return e.first == keyframe_id; }),
                  ordered.end());
  }
  // Children hang on to the erased keyframe's parent (always older, so no cycle forms).
  Id anchor = kf->parent_id;
  if (anchor == kInvalidId || !keyframes_.count(anchor)) anchor = first_keyframe_id_;
  SlamKeyframe& parent = keyframes_.at(anchor);
  for (const Id child_id : kf->child_ids) {
    SlamKeyframe* child = FindKeyframe(child_id);
    if (child == nullptr) continue;
    child->parent_id = anchor;
    parent.child_ids.push_back(child_id);
  }
  auto& siblings = parent.child_ids;
  siblings.erase(std::remove(siblings.begin(), siblings.end(), keyframe_id), siblings.end());
  erased_keyframes_[keyframe_id] = {kf->segment, anchor,
                                    kf->cam_from_world * parent.cam_from_world.Inverse(),
                                    kf->scale, parent.scale};
  keyframes_.erase(keyframe_id);
}

void SlamMap::UpdateLandmarkGeometry(Id landmark_id) {
  SlamLandmark* landmark = FindLandmark(landmark_id);
  if (landmark == nullptr || landmark->observations.empty()) return;
  Eigen::Vector3d normal_sum = Eigen::Vector3d::Zero();
  for (const Observation& o : landmark->observations) {
    const SlamKeyframe& kf = keyframes_.at(o.keyframe_id);
    const Eigen::Vector3d ray = landmark->position_in_world - kf.Center();
    const double norm = ray.norm();
    if (norm > 0.0) normal_sum += ray / norm;
  }
  if (normal_sum.norm() > 0.0) landmark->mean_viewing_direction = normal_sum.normalized();

  Id reference = landmark->reference_keyframe_id;
  const Observation* reference_obs = nullptr;
  for (const Observation& o : landmark->observations) {
    if (o.keyframe_id == reference) reference_obs = &o;
  }
  if (reference_obs == nullptr) {
    reference_obs = &landmark->observations.front();
    landmark->reference_keyframe_id = reference_obs->keyframe_id;
  }
  const SlamKeyframe& ref_kf = keyframes_.at(reference_obs->keyframe_id);
  const double distance = (landmark->position_in_world - ref_kf.Center()).norm();
  const int octave = ref_kf.keypoints[reference_obs->keypoint_index].octave;
  const ScaleLevels& levels = ref_kf.scale_levels;
  landmark->max_distance = distance * levels.Scale(octave);
  landmark->min_distance = landmark->max_distance / levels.Scale(levels.num_levels() - 1);

  // Representative descriptor: least median Hamming distance to the others (ORB-SLAM).
  const int n = landmark->NumObservations();
  if (n == 1) {
    const Observation& o = landmark->observations.front();
    landmark->descriptor = keyframes_.at(o.keyframe_id).descriptors[o.keypoint_index];
    return;
  }
  std::vector<const OrbDescriptor*> descriptors(n);
  for (int i = 0; i < n; ++i) {
    const Observation& o = landmark->observations[i];
    descriptors[i] = &keyframes_.at(o.keyframe_id).descriptors[o.keypoint_index];
  }
  std::vector<int> row(n);
  int best_median = 1 << 30;
  int best = 0;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) row[j] = i == j ? 0 : HammingDistance(*descriptors[i], *descriptors[j]);
    std::nth_element(row.begin(), row.begin() + (n - 1) / 2, row.end());
    const int median = row[(n - 1) / 2];
    if (median < best_median) {
      best_median = median;
      best = i;
    }
  }
  landmark->descriptor = *descriptors[best];
}

namespace {

void SortCovisibles(SlamKeyframe* kf) {
  kf->ordered_covisibles.assign(kf->covisibility_weights.begin(), kf->covisibility_weights.end());
  std::sort(kf->ordered_covisibles.begin(), kf->ordered_covisibles.end(),
            [](const auto& a, const auto& b) {
              return a.second != b.second ? a.second > b.second : a.first < b.first;
            });
}

}  // namespace

void SlamMap::UpdateCovisibility(Id keyframe_id) {
  SlamKeyframe* kf = FindKeyframe(keyframe_id);
  if (kf == nullptr) return;
  std::map<Id, int> counts;
  for (const Id landmark_id : kf->landmark_ids) {
    if (landmark_id == kInvalidId) continue;
    const SlamLandmark* landmark = FindLandmark(landmark_id);
    if (landmark == nullptr) continue;
    for (const Observation& o : landmark->observations) {
      if (o.keyframe_id != keyframe_id) ++counts[o.keyframe_id];
    }
  }
  std::map<Id, int> weights;
  Id strongest = kInvalidId;
  int strongest_weight = 0;
  for (const auto& [id, count] : counts) {
    if (count > strongest_weight) {
      strongest = id;
      strongest_weight = count;
    }
    if (count >= kCovisibilityThreshold) weights[id] = count;
  }
  if (weights.empty() && strongest != kInvalidId) weights[strongest] = strongest_weight;

  for (const auto& [id, weight] : kf->covisibility_weights) {
    if (weights.count(id)) continue;
    SlamKeyframe* neighbour = FindKeyframe(id);
    if (neighbour == nullptr) continue;
    neighbour->covisibility_weights.erase(keyframe_id);
    SortCovisibles(neighbour);
  }
  for (const auto& [id, weight] : weights) {
    SlamKeyframe& neighbour = keyframes_.at(id);
    neighbour.covisibility_weights[keyframe_id] = weight;
    SortCovisibles(&neighbour);
  }
  kf->covisibility_weights = std::move(weights);
  SortCovisibles(kf);

  if (kf->parent_id == kInvalidId && keyframe_id != first_keyframe_id_) {
    for (const auto& [id, weight] : kf->ordered_covisibles) {
      if (id < keyframe_id) {
        kf->parent_id = id;
        break;
      }
    }
    if (kf->parent_id == kInvalidId) kf->parent_id = first_keyframe_id_;
    keyframes_.at(kf->parent_id).child_ids.push_back(keyframe_id);
  }
}

void SlamMap::RebuildCovisibility() {
  // Keyframes by index in id order.
  std::vector<SlamKeyframe*> by_index;
  std::map<Id, int> index_of;
  for (auto& [id, kf] : keyframes_) {
    index_of[id] = static_cast<int>(by_index.size());
    by_index.push_back(&kf);
  }
  const int n = static_cast<int>(by_index.size());
  // Per keyframe: the keyframes sharing each of its landmarks, one entry per shared landmark.
  std::vector<std::vector<int>> sharing(n);
  std::vector<int> observers;
  for (const auto& [landmark_id, landmark] : landmarks_) {
    observers.clear();
    for (const Observation& o : landmark.observations) {
      const auto it = index_of.find(o.keyframe_id);
      if (it != index_of.end()) observers.push_back(it->second);
    }
    for (const int a : observers) {
      for (const int b : observers) {
        if (a != b) sharing[a].push_back(b);
      }
    }
  }
  // W_k of UpdateCovisibility: neighbours with >= kCovisibilityThreshold shared landmarks, or
  // the single strongest (smallest id among equals) when there is none.
  std::vector<std::vector<std::pair<int, int>>> selected(n);  // (index, weight)
  for (int k = 0; k < n; ++k) {
    std::vector<int>& list = sharing[k];
    std::sort(list.begin(), list.end());
    int strongest = -1, strongest_weight = 0;
    for (std::size_t i = 0; i < list.size();) {
      std::size_t j = i;
      while (j < list.size() && list[j] == list[i]) ++j;
      const int weight = static_cast<int>(j - i);
      if (weight > strongest_weight) strongest = list[i], strongest_weight = weight;
      if (weight >= kCovisibilityThreshold) selected[k].emplace_back(list[i], weight);
      i = j;
    }
    if (selected[k].empty() && strongest >= 0) selected[k].emplace_back(strongest, strongest_weight);
  }
  // Processing in id order leaves an edge between a and b (a < b) exactly when a is in W_b: b's
  // update, the last to touch the pair, writes both sides or erases them.
  for (SlamKeyframe* kf : by_index) {
    kf->covisibility_weights.clear();
    kf->parent_id = kInvalidId;
    kf->child_ids.clear();
  }
  for (int b = 0; b < n; ++b) {
    for (const auto& [a, weight] : selected[b]) {
      if (a > b) continue;
      by_index[a]->covisibility_weights[by_index[b]->id] = weight;
      by_index[b]->covisibility_weights[by_index[a]->id] = weight;
    }
  }
  for (SlamKeyframe* kf : by_index) SortCovisibles(kf);
  // Parents as UpdateCovisibility picks them when k arrives: the heaviest older entry of W_k
  // (ties: smaller id), else the first keyframe.
  for (int k = 0; k < n; ++k) {
    SlamKeyframe* kf = by_index[k];
    if (kf->id == first_keyframe_id_) continue;
    std::pair<int, int> best(-1, 0);  // (index, weight)
    for (const auto& [a, weight] : selected[k]) {
      if (a < k && (weight > best.second || (weight == best.second && a < best.first))) {
        best = {a, weight};
      }
    }
    kf->parent_id = best.first >= 0 ? by_index[best.first]->id : first_keyframe_id_;
    keyframes_.at(kf->parent_id).child_ids.push_back(kf->id);
  }
}

std::vector<Id> SlamMap::CovisibleKeyframes(Id keyframe_id, int max_count) const {
  std::vector<Id> out;
  const SlamKeyframe* kf = FindKeyframe(keyframe_id);
  if (kf == nullptr) return out;
  for (const auto& [id, weight] : kf->ordered_covisibles) {
    if (static_cast<int>(out.size()) >= max_count) break;
    out.push_back(id);
  }
  return out;
}

const SlamKeyframe* SlamMap::FindKeyframe(Id id) const {
  auto it = keyframes_.find(id);
  return it == keyframes_.end() ? nullptr : &it->second;
}
SlamKeyframe* SlamMap::FindKeyframe(Id id) {
  auto it = keyframes_.find(id);
  return it == keyframes_.end() ? nullptr : &it->second;
}
const SlamLandmark* SlamMap::FindLandmark(Id id) const {
  auto it = landmarks_.find(id);
  return it == landmarks_.end() ? nullptr : &it->second;
}
SlamLandmark* SlamMap::FindLandmark(Id id) {
  auto it = landmarks_.find(id);
  return it == landmarks_.end() ? nullptr : &it->second;
}

int SlamMap::SegmentWithLoadedKeyframes() const {
  for (const auto& [id, kf] : keyframes_) {
    if (kf.loaded) return kf.segment;
  }
  return -1;
}

int SlamMap::OutputSegment() const {
  const int active = active_segment_;
  if (ActiveSegmentRegistered()) return active;
  const int loaded = SegmentWithLoadedKeyframes();
  if (loaded == active) return active;
  std::map<int, int> own_keyframes;
  for (const auto& [id, kf] : keyframes_) {
    if (!kf.loaded) ++own_keyframes[kf.segment];
  }
  int best = active;
  int best_count = own_keyframes.count(active) ? own_keyframes.at(active) : 0;
  bool best_registered = false;
  for (const auto& [segment, count] : own_keyframes) {
    const bool registered = SegmentInLineCloudFrame(segment);
    if ((registered && !best_registered) ||
        (registered == best_registered && count > best_count)) {
      best = segment;
      best_count = count;
      best_registered = registered;
    }
  }
  return best;
}

Map SlamMap::ToMap(const CameraParams& camera_params, Id camera_id, int segment) const {
  Map map;
  if (segment < 0) segment = active_segment_;
  // The line cloud goes along when the client map is in its frame (or there is no client map).
  // (The registered segment is always one in the line cloud's frame.)
  const bool with_lines = HasLineCloud() && (SegmentInLineCloudFrame(segment) ||
                                             NumKeyframesInSegment(segment) == 0);
  if (with_lines) {
    // The client camera shares the id of a server camera with the same parameters, and takes
    // a free id when camera_id names another camera.
    map.cameras = server_cameras_;
    for (const auto& [id, params] : server_cameras_) {
      if (SameCameraParams(params, camera_params)) camera_id = id;
    }
    auto same = map.cameras.find(camera_id);
    if (same != map.cameras.end() && !SameCameraParams(same->second, camera_params)) {
      camera_id = map.cameras.rbegin()->first + 1;
    }
  }
  if (!with_lines || NumKeyframesInSegment(segment) > 0) {
    map.cameras[camera_id] = camera_params;
  }
  // Rough isotropic point uncertainty: one pixel's angle at the point's distance.
  double pixel_angle = 1.0 / 500.0;
  if (camera_params.model != CameraModel::kEquirectangular && camera_params.fx > 0) {
    pixel_angle = 1.0 / camera_params.fx;
  } else if (camera_params.cols > 0) {
    pixel_angle = 2.0 * M_PI / camera_params.cols;
  }
  for (const auto& [id, kf] : keyframes_) {
    if (kf.segment != segment) continue;
    Keyframe& out = map.keyframes[id];
    out.id = id;
    out.camera_id = camera_id;
    out.timestamp = kf.timestamp;
    out.cam_from_world = kf.cam_from_world;
    out.keypoints = kf.keypoints;
    out.descriptors = kf.descriptors;
  }
  for (const auto& [id, landmark] : landmarks_) {
    if (landmark.observations.empty() || landmark.segment != segment) continue;
    if (with_lines && landmark.IsRestored()) continue;  // written as its line's X' below
    PointLandmark& out = map.points[id];
    out.id = id;
    out.position = landmark.position_in_world;
    const SlamKeyframe* ref = FindKeyframe(landmark.reference_keyframe_id);
    const double distance =
        ref ? (landmark.position_in_world - ref->Center()).norm() : landmark.max_distance;
    const double sigma = std::max(1e-9, distance * pixel_angle);
    out.covariance = Eigen::Matrix3d::Identity() * sigma * sigma;
    out.descriptor = landmark.descriptor;
    out.observations = landmark.observations;
  }
  for (const auto& [a, b] : loop_edges_) {
    if (map.keyframes.count(a) && map.keyframes.count(b)) map.loop_edges.emplace_back(a, b);
  }
  if (!with_lines) return map;
  for (const auto& [id, line] : lines_) {
    LineLandmark& out = map.lines[id];
    out.id = id;
    out.line = line.line;
    out.information = line.information;
    out.descriptor = line.descriptor;
    out.server_keyframe_ids = line.server_keyframe_ids;
    const SlamLandmark* restored = FindLandmark(line.restored_landmark_id);
    if (restored != nullptr && restored->segment == segment &&
        !restored->observations.empty()) {
      out.restored_point = restored->position_in_world;
      out.observations = restored->observations;
    }
  }
  for (const auto& [id, kf] : server_keyframes_) {
    ServerKeyframe& out = map.server_keyframes[id];
    out.id = id;
    out.camera_id = kf.camera_id;
    out.timestamp = kf.timestamp;
    out.cam_from_world = kf.cam_from_world;
    out.line_ids = kf.line_ids;
  }
  return map;
}

void SlamMap::Transform(double scale) {
  LCV_CHECK(scale > 0.0);
  MoveSegment(active_segment_, active_segment_,
              Sim3d(scale, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero()));
}

int SlamMap::StartSegment() {
  active_segment_ = num_segments_++;
  first_keyframe_id_ = kInvalidId;
  return active_segment_;
}

int SlamMap::NumKeyframesInSegment(int segment) const {
  int count = 0;
  for (const auto& [id, kf] : keyframes_) count += kf.segment == segment;
  return count;
}

void SlamMap::EraseSegment(int segment) {
  for (auto it = landmarks_.begin(); it != landmarks_.end();) {
    if (it->second.segment == segment) {
      UnlinkRestored(it->second);
      it = landmarks_.erase(it);
    } else {
      ++it;
    }
  }
  if (registered_segment_ == segment) registered_segment_ = -1;
  segments_in_line_cloud_frame_.erase(segment);
  for (auto it = keyframes_.begin(); it != keyframes_.end();) {
    it = it->second.segment == segment ? keyframes_.erase(it) : std::next(it);
  }
  for (auto it = erased_keyframes_.begin(); it != erased_keyframes_.end();) {
    it = it->second.segment == segment ? erased_keyframes_.erase(it) : std::next(it);
  }
  loop_edges_.erase(std::remove_if(loop_edges_.begin(), loop_edges_.end(),
                                   [&](const std::pair<Id, Id>& e) {
                                     return !keyframes_.count(e.first) ||
                                            !keyframes_.count(e.second);
                                   }),
                    loop_edges_.end());
  if (segment == active_segment_) first_keyframe_id_ = kInvalidId;
}

void SlamMap::MoveSegment(int from, int to, const Sim3d& to_world_from_from_world) {
  const double s = to_world_from_from_world.scale;
  LCV_CHECK(s > 0.0);
  // A registered segment moved into another one's frame is no longer in the line cloud's frame.
  if (registered_segment_ == from && from != to) registered_segment_ = -1;
  if (from != to) segments_in_line_cloud_frame_.erase(from);
  const Sim3d from_world_from_to_world = to_world_from_from_world.Inverse();
  for (auto& [id, kf] : keyframes_) {
    if (kf.segment != from) continue;
    // cam_from_to_world = [R | t] * from_world_from_to_world, a similarity of scale 1/s; as a
    // rigid pose of the camera in the moved map: [R' | t' * s].
    const Sim3d moved = Sim3d(kf.cam_from_world) * from_world_from_to_world;
    kf.cam_from_world = Rigid3d(moved.rotation.normalized(), moved.translation / moved.scale);
    kf.scale *= s;
    kf.segment = to;
  }
  for (auto& [id, landmark] : landmarks_) {
    if (landmark.segment != from) continue;
    landmark.position_in_world = to_world_from_from_world * landmark.position_in_world;
    landmark.min_distance *= s;
    landmark.max_distance *= s;
    landmark.segment = to;
  }
  for (auto& [id, erased] : erased_keyframes_) {
    if (erased.segment != from) continue;
    erased.erased_from_anchor.translation *= s;
    erased.erased_scale *= s;
    erased.anchor_scale *= s;
    erased.segment = to;
  }
  if (from != to && active_segment_ == from) {
    active_segment_ = to;
    first_keyframe_id_ = kInvalidId;
    for (const auto& [id, kf] : keyframes_) {
      if (kf.segment == to) {
        first_keyframe_id_ = id;  // the smallest id: keyframes_ is ordered
        break;
      }
    }
  }
}

}  // namespace lcv::slam
