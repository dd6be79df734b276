#include "slam/local_mapping.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <set>

#include "slam/bow/vocabulary.h"
#include "slam/data/frame_anchor.h"
#include "slam/module/restored_point_release.h"
#include "slam/optimize/bundle_adjustment.h"
#include "slam/optimize/motion_only_ba.h"
#include "slam/optimize/slam_map_bundle.h"
#include "slam/solve/triangulation.h"

namespace lcv::slam {
namespace {

constexpr double kChi2TwoDof = 5.991;

// Squared pixel error of a world point against a keypoint of a keyframe; infinity when the
// camera cannot image it.
double SquaredReprojectionError(const SlamKeyframe& kf, const Eigen::Vector3d& p_in_world,
                                const Keypoint& kp) {
  const std::optional<Eigen::Vector2d> px = kf.camera->Project(kf.cam_from_world * p_in_world);
  if (!px) return std::numeric_limits<double>::infinity();
  return (*px - Eigen::Vector2d(kp.x, kp.y)).squaredNorm();
}

}  // namespace

LocalMapper::LocalMapper(const Camera& camera, const SystemOptions& options)
    : camera_(camera), options_(options) {
  epipolar_options_.radians_per_pixel = RadiansPerPixel(camera);
}

void LocalMapper::ClearActiveSegmentState() {
  new_keyframe_ids_.clear();
  snapshot_.reset();
  keyframe_counter_ = 0;
  recent_landmarks_.clear();
  low_restored_streak_ = 0;
}

void LocalMapper::Reset() {
  map_.ClearClientData();
  database_.Clear();
  ClearActiveSegmentState();
  // Segment numbers start again at 0: the views of an old segment 0 must not join the new one's.
  line_cloud_views_.clear();
  line_cloud_views_segment_ = -1;
  line_cloud_view_localizations_ = 0;
}

void LocalMapper::ArchiveActiveSegment() {
  ClearActiveSegmentState();
  map_.StartSegment();
}

void LocalMapper::DiscardActiveSegment() {
  const int active = map_.active_segment();
  if (map_.NumKeyframesInSegment(active) == static_cast<int>(map_.keyframes().size())) {
    Reset();
    return;
  }
  for (const auto& [id, kf] : map_.keyframes()) {
    if (kf.segment == active && database_.Contains(id)) database_.Erase(id);
  }
  map_.EraseSegment(active);
  ClearActiveSegmentState();
}

std::optional<InitialMap> LocalMapper::Initialize(const Frame& reference, const Frame& current,
                                                  const Initialization& initialization) {
  DiscardActiveSegment();
  Frame first = reference;
  first.cam_from_world = Rigid3d();
  Frame second = current;
  second.cam_from_world = initialization.current_from_reference;
  const Id kf1 = map_.AddKeyframe(first).id;
  const Id kf2 = map_.AddKeyframe(second).id;
  for (size_t k = 0; k < initialization.matches.size(); ++k) {
    const Id id = map_.AddLandmark(initialization.points_in_reference[k], kf1).id;
    map_.AddObservation(id, kf1, initialization.matches[k].first);
    map_.AddObservation(id, kf2, initialization.matches[k].second);
    map_.UpdateLandmarkGeometry(id);
  }
  map_.UpdateCovisibility(kf1);
  map_.UpdateCovisibility(kf2);
  RunGlobalBundleAdjustment(20);

  const SlamKeyframe& first_kf = map_.keyframes().at(kf1);
  const SlamKeyframe& second_kf = map_.keyframes().at(kf2);
  const double median = first_kf.MedianLandmarkDistance(map_);
  const int min_points = std::max(1, options_.initializer.two_view.min_num_triangulated / 2);
  if (!(median > 0.0) || second_kf.NumLandmarks() < min_points) {
    DiscardActiveSegment();
    return std::nullopt;
  }
  map_.Transform(1.0 / median);
  for (const auto& [id, landmark] : map_.landmarks()) map_.UpdateLandmarkGeometry(id);
  AddToDatabase(kf1);
  AddToDatabase(kf2);
  TryRegisterInLineCloud(kf2);
  keyframe_counter_ = 2;
  Publish(kf2);

  InitialMap result;
  result.reference_keyframe_id = kf1;
  result.current_keyframe_id = kf2;
  result.current_cam_from_world = second_kf.cam_from_world;
  result.current_from_reference = second_kf.cam_from_world * first_kf.cam_from_world.Inverse();
  result.current_keyframe_scale = second_kf.scale;
  result.current_landmark_ids = second_kf.landmark_ids;
  return result;
}

void LocalMapper::ProcessKeyframe(const Frame& tracked) {
  // Live, the map may have moved since the snapshot the frame was tracked in (registration,
  // loop correction, global BA): the keyframe enters it re-anchored to its reference.
  std::optional<Frame> reanchored;
  if (const std::optional<Rigid3d> pose = ReanchoredKeyframePose(map_, tracked)) {
    reanchored = tracked;
    reanchored->cam_from_world = *pose;
    ++num_keyframes_reanchored_;
  }
  const Frame& frame = reanchored ? *reanchored : tracked;
  SlamKeyframe& keyframe = map_.AddKeyframe(frame);
  keyframe.made_in_line_cloud = map_.ActiveSegmentRegistered() && !map_.LineCloudDetached();
  const Id id = keyframe.id;
  ++keyframe_counter_;
  InsertKeyframe(frame, id);
  CullRecentLandmarks(id);
  TriangulateNewLandmarks(id, frame.reference_keyframe_id);
  if (options_.mapping.fuse_duplicates) FuseDuplicates(id);
  RunLocalBundleAdjustment(id);
  if (options_.mapping.cull_keyframes) CullRedundantKeyframes(id);
  AddToDatabase(id);
  TryRegisterInLineCloud(id);
  UpdateLineCloudDetachment(id);
  Publish(id);
}

void LocalMapper::ComputeBow(SlamKeyframe* keyframe) const {
  if (!options_.vocabulary || options_.vocabulary->empty()) return;
  if (!keyframe->bow.empty()) return;  // computed by tracking (relocalization) already
  options_.vocabulary->Transform(keyframe->descriptors, &keyframe->bow.overwrite(),
                                 &keyframe->direct_index.overwrite(), kDirectIndexLevel);
}

void LocalMapper::AddToDatabase(Id keyframe_id) {
  SlamKeyframe* keyframe = map_.FindKeyframe(keyframe_id);
  if (keyframe == nullptr) return;
  // Only the loop closer takes them; without it the list would only grow.
  if (options_.LoopClosingActive()) new_keyframe_ids_.push_back(keyframe_id);
  if (!options_.vocabulary || options_.vocabulary->empty()) return;
  ComputeBow(keyframe);
  database_.Add(keyframe_id, keyframe->bow);
}

std::vector<Id> LocalMapper::TakeNewKeyframeIds() {
  std::vector<Id> ids;
  ids.swap(new_keyframe_ids_);
  return ids;
}

Id LocalMapper::LoadMap(SlamMap map) {
  Reset();
  map_ = std::move(map);
  LCV_CHECK(!map_.keyframes().empty()) << "LoadMap: a map without keyframes";
  for (const auto& [id, keyframe] : map_.keyframes()) AddToDatabase(id);
  new_keyframe_ids_.clear();  // loaded keyframes are not new: no loop detection on them
  keyframe_counter_ = map_.keyframes().size();
  const Id newest = map_.keyframes().rbegin()->first;
  Publish(newest);
  return newest;
}

std::shared_ptr<const LocalMapSnapshot> LocalMapper::PublishAround(
    Id keyframe_id, const std::optional<Eigen::Vector3d>& lines_near) {
  lines_near_ = lines_near;
  lines_near_keyframe_id_ = keyframe_id;
  Publish(keyframe_id);
  return snapshot_;
}

void LocalMapper::Republish() {
  if (map_.keyframes().empty()) return;
  Id reference = snapshot_ ? snapshot_->reference_keyframe_id : kInvalidId;
  if (map_.FindKeyframe(reference) == nullptr) reference = map_.keyframes().rbegin()->first;
  Publish(reference);
}

void LocalMapper::InsertKeyframe(const Frame& frame, Id keyframe_id) {
  std::vector<Id> linked;
  for (int i = 0; i < frame.num_keypoints(); ++i) {
    Id landmark_id = frame.landmark_ids[i];
    if (landmark_id == kInvalidId || frame.is_outlier[i]) continue;
    // A keypoint tracking matched to a line (2D point - 3D line): its line's X', restored now
    // when the line has none (the only place X' are created after registration).
    if (map_.FindLine(landmark_id) != nullptr) landmark_id = RestoreLinePoint(frame, i, keyframe_id);
    if (map_.FindLandmark(landmark_id) == nullptr) continue;  // culled meanwhile
    if (map_.AddObservation(landmark_id, keyframe_id, i)) linked.push_back(landmark_id);
  }
  for (const Id landmark_id : linked) map_.UpdateLandmarkGeometry(landmark_id);
  map_.UpdateCovisibility(keyframe_id);
}

Id LocalMapper::RestoreLinePoint(const Frame& frame, int keypoint_index, Id keyframe_id) {
  const Id line_id = frame.landmark_ids[keypoint_index];
  const SlamLine& line = *map_.FindLine(line_id);
  if (!map_.ActiveSegmentRegistered()) return kInvalidId;  // matched before a reset
  if (line.restored_landmark_id != kInvalidId) {
    const SlamLandmark* restored = map_.FindLandmark(line.restored_landmark_id);
    if (restored != nullptr && restored->segment == map_.active_segment()) return restored->id;
    return kInvalidId;
  }
  if (frame.bearings[keypoint_index].squaredNorm() < 0.5) return kInvalidId;
  // The paper's initial X' (Sec. 3.4): midway between the keypoint's ray and the line; local BA
  // then refines it with e_pL.
  const Eigen::Vector3d position =
      InitialRestoredPoint(frame.cam_from_world, frame.bearings[keypoint_index], line.line);
  const Id id = map_.AddLandmark(position, keyframe_id).id;
  map_.RestoreOnLine(id, line_id);
  ++num_restored_;
  return id;
}

void LocalMapper::CullRecentLandmarks(Id keyframe_id) {
  std::vector<std::pair<Id, std::uint64_t>> kept;
  kept.reserve(recent_landmarks_.size());
  for (const auto& [landmark_id, created] : recent_landmarks_) {
    const SlamLandmark* landmark = map_.FindLandmark(landmark_id);
    if (landmark == nullptr) continue;
    const std::uint64_t age = keyframe_counter_ - created;
    if (age >= 2 && landmark->NumObservations() <= 2) {
      map_.EraseLandmark(landmark_id);
    } else if (age < 3) {
      kept.emplace_back(landmark_id, created);
    }
  }
  recent_landmarks_ = std::move(kept);
}

int LocalMapper::TriangulateNewLandmarks(Id keyframe_id, Id reference_keyframe_id) {
  const SlamKeyframe& kf = map_.keyframes().at(keyframe_id);
  std::vector<Id> neighbours =
      map_.CovisibleKeyframes(keyframe_id, options_.mapping.max_triangulation_neighbours);
  // The keyframe the frame was tracked against, also when it shares few points with it (a
  // two-view pose in a sharp turn: the points both see are what the next frames need).
  const SlamKeyframe* reference = map_.FindKeyframe(reference_keyframe_id);
  if (reference != nullptr && reference_keyframe_id != keyframe_id &&
      reference->segment == kf.segment &&
      std::find(neighbours.begin(), neighbours.end(), reference_keyframe_id) == neighbours.end()) {
    neighbours.push_back(reference_keyframe_id);
  }
  const ScaleLevels& levels = kf.scale_levels;
  const double ratio_factor = 1.5 * levels.scale_factor();
  const double min_parallax_rad = options_.mapping.min_parallax_deg * M_PI / 180.0;
  std::vector<std::pair<int, int>> pairs;
  int created = 0;
  for (const Id neighbour_id : neighbours) {
    const SlamKeyframe& other = map_.keyframes().at(neighbour_id);
    if (other.loaded && !options_.mapping.use_loaded_keypoints) continue;
    const double baseline = (kf.Center() - other.Center()).norm();
    const double median = other.MedianLandmarkDistance(map_);
    if (!(median > 0.0) || baseline / median < 0.01) continue;
    MatchForTriangulation(kf, other, epipolar_options_, &pairs);
    for (const auto& [i1, i2] : pairs) {
      if (kf.landmark_ids[i1] != kInvalidId || other.landmark_ids[i2] != kInvalidId) continue;
      const std::optional<TriangulatedPoint> point =
          TriangulateBearings(kf.cam_from_world, other.cam_from_world, kf.bearings[i1],
                              other.bearings[i2], min_parallax_rad);
      if (!point) continue;
      const Eigen::Vector3d& X = point->point_in_world;
      const Keypoint& kp1 = kf.keypoints[i1];
      const Keypoint& kp2 = other.keypoints[i2];
      const double s1 = levels.Scale(kp1.octave);
      const double s2 = other.scale_levels.Scale(kp2.octave);
      if (SquaredReprojectionError(kf, X, kp1) > kChi2TwoDof * s1 * s1) continue;
      if (SquaredReprojectionError(other, X, kp2) > kChi2TwoDof * s2 * s2) continue;
      // Scale consistency: the distance ratio must agree with the octave ratio.
      const double d1 = (X - kf.Center()).norm();
      const double d2 = (X - other.Center()).norm();
      if (!(d1 > 0.0) || !(d2 > 0.0)) continue;
      const double ratio_distance = d2 / d1;
      const double ratio_octave = s1 / s2;
      if (ratio_distance * ratio_factor < ratio_octave ||
          ratio_distance > ratio_octave * ratio_factor) {
        continue;
      }
      const Id landmark_id = map_.AddLandmark(X, keyframe_id).id;
      map_.AddObservation(landmark_id, keyframe_id, i1);
      map_.AddObservation(landmark_id, neighbour_id, i2);
      map_.UpdateLandmarkGeometry(landmark_id);
      recent_landmarks_.emplace_back(landmark_id, keyframe_counter_);
      ++created;
    }
  }
  return created;
}

namespace {

// Copies keyframes (free or fixed) and the given landmarks with all their observations by those
// keyframes into a BundleProblem (SlamMapBundleBuilder: points with e_pP, X' with e_pL), solves
// it and writes the results back; outlier observations are removed from the map. Returns
// whether options.should_stop ended the solve early.
bool SolveAndWriteBack(const std::vector<Id>& free_keyframes, const std::vector<Id>& landmarks,
                       Id gauge_keyframe, bool hold_loaded, const BundleOptions& options,
                       const LineCloudBundleOptions* line_cloud, SlamMap* map) {
  BundleProblem problem;
  SlamMapBundleBuilder builder(*map, &problem);
  for (const Id id : free_keyframes) {
    const bool fixed = id == gauge_keyframe || (hold_loaded && map->FindKeyframe(id)->loaded);
    builder.AddKeyframe(id, fixed);
  }
  for (const Id landmark_id : landmarks) builder.AddLandmark(landmark_id);
  if (problem.observations.empty()) return false;
  std::vector<Id> line_ids;
  if (line_cloud != nullptr && !problem.lines.empty()) {
    line_ids = AddLineCloudToBundle(*map, *line_cloud, &problem);
  }
  const BundleReport report = SolveBundleAdjustment(options, &problem);
  if (!report.success) return report.stopped_early;
  for (const BundleKeyframe& bk : problem.keyframes) {
    if (bk.fixed) continue;
    Rigid3d& pose = map->FindKeyframe(bk.id)->cam_from_world;
    pose = bk.cam_from_world;
    pose.rotation.normalize();
  }
  const std::vector<Id> written = WriteBackLandmarkPositions(problem, map);
  if (!line_ids.empty()) WriteBackLineCloud(problem, line_ids, map);
  for (size_t k = 0; k < problem.observations.size(); ++k) {
    if (problem.observations[k].outlier) {
      const SlamMapBundleBuilder::Link& link = builder.links()[k];
      map->RemoveObservation(link.landmark_id, link.keyframe_id, 2);
    }
  }
  for (const Id id : written) map->UpdateLandmarkGeometry(id);
  return report.stopped_early;
}

}  // namespace

void LocalMapper::RunLocalBundleAdjustment(Id keyframe_id) {
  std::vector<Id> local{keyframe_id};
  for (const Id id : map_.CovisibleKeyframes(keyframe_id, options_.mapping.max_local_ba_keyframes)) {
    local.push_back(id);
  }
  std::set<Id> landmark_set;
  for (const Id id : local) {
    for (const Id landmark_id : map_.keyframes().at(id).landmark_ids) {
      if (landmark_id != kInvalidId) landmark_set.insert(landmark_id);
    }
  }
  BundleOptions ba_options;
  ba_options.max_iterations = options_.mapping.local_ba_iterations;
  ba_options.max_refine_iterations = options_.mapping.local_ba_iterations;
  ba_options.should_stop = local_ba_should_stop_;
  // In a registered segment the server's lines hold the gauge (and the scale) through the X'
  // terms: the first keyframe is not fixed to where registration put it.
  int num_restored = 0;
  for (const Id id : landmark_set) {
    const SlamLandmark* landmark = map_.FindLandmark(id);
    num_restored += landmark != nullptr && landmark->IsRestored();
  }
  const Id gauge = map_.ActiveSegmentRegistered() && num_restored >= kMinRestoredForLineGauge
                       ? kInvalidId
                       : map_.first_keyframe_id();
  const auto start = std::chrono::steady_clock::now();
  LineCloudBundleOptions line_cloud;
  line_cloud.free_server_keyframes = true;
  line_cloud.max_free_server_keyframes = options_.line_cloud.local_ba_free_server_keyframes;
  line_cloud.virtual_from_published = options_.line_cloud.virtual_from_published;
  line_cloud.virtual_sigma_px = options_.line_cloud.virtual_sigma_px;
  const bool with_line_cloud = map_.ActiveSegmentRegistered() &&
                               options_.line_cloud.local_ba_frees_line_cloud &&
                               num_restored >= kMinRestoredForLineGauge;
  const std::vector<Id> landmarks(landmark_set.begin(), landmark_set.end());
  num_local_ba_stopped_early_ +=
      SolveAndWriteBack(local, landmarks, gauge, options_.mapping.hold_loaded_keyframes,
                        ba_options, with_line_cloud ? &line_cloud : nullptr, &map_);
  if (map_.ActiveSegmentRegistered() && options_.line_cloud.release_off_line_deg > 0.0) {
    restored_points_released_ += ReleaseRestoredPointsOffTheirLines(
        landmarks, map_.keyframes().at(keyframe_id).Center(),
        options_.line_cloud.release_off_line_deg * M_PI / 180.0, &map_);
  }
  ++num_local_ba_runs_;
  local_ba_ms_ +=
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

void LocalMapper::RunGlobalBundleAdjustment(int iterations) {
  // The active segment (the two initial keyframes).
  const int segment = map_.active_segment();
  std::vector<Id> keyframes;
  for (const auto& [id, kf] : map_.keyframes()) {
    if (kf.segment == segment) keyframes.push_back(id);
  }
  std::vector<Id> landmarks;
  for (const auto& [id, landmark] : map_.landmarks()) {
    if (landmark.segment == segment) landmarks.push_back(id);
  }
  BundleOptions ba_options;
  ba_options.max_iterations = iterations;
  ba_options.max_refine_iterations = iterations;
  SolveAndWriteBack(keyframes, landmarks, map_.first_keyframe_id(), /*hold_loaded=*/false,
                    ba_options, nullptr, &map_);
}

int LocalMapper::CullRedundantKeyframes(Id keyframe_id) {
  int erased = 0;
  const std::vector<Id> neighbours = map_.CovisibleKeyframes(keyframe_id, 1 << 20);
  for (const Id id : neighbours) {
    if (id == map_.first_keyframe_id() || id == keyframe_id) continue;
    // Loop edges hold the essential graph together (ORB-SLAM's "not erase" flag).
    if (map_.HasLoopEdge(id)) continue;
    const SlamKeyframe* kf = map_.FindKeyframe(id);
    if (kf == nullptr) continue;
    int num_points = 0;
    int redundant = 0;
    for (size_t i = 0; i < kf->landmark_ids.size(); ++i) {
      const SlamLandmark* landmark = map_.FindLandmark(kf->landmark_ids[i]);
      if (landmark == nullptr) continue;
      ++num_points;
      if (landmark->NumObservations() <= 3) continue;
      const int octave = kf->keypoints[i].octave;
      int others = 0;
      for (const Observation& o : landmark->observations) {
        if (o.keyframe_id == id) continue;
        const SlamKeyframe& other = map_.keyframes().at(o.keyframe_id);
        if (other.keypoints[o.keypoint_index].octave <= octave + 1) ++others;
        if (others >= 3) break;
      }
      if (others >= 3) ++redundant;
    }
    if (num_points > 0 && redundant > options_.mapping.redundant_keyframe_ratio * num_points) {
      map_.EraseKeyframe(id);
      database_.Erase(id);
      ++erased;
    }
  }
  return erased;
}

void LocalMapper::Publish(Id keyframe_id) {
  LocalMapSnapshotOptions snapshot_options;
  snapshot_options.max_server_keyframes = options_.line_cloud.snapshot_server_keyframes;
  if (keyframe_id != lines_near_keyframe_id_) lines_near_.reset();
  snapshot_options.lines_near = lines_near_;
  snapshot_ = std::make_shared<const LocalMapSnapshot>(
      MakeLocalMapSnapshot(map_, keyframe_id, snapshot_options, ++snapshot_version_));
}

}  // namespace lcv::slam

