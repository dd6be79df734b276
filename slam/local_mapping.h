#pragma once
// The local-mapping stage of System (internal to slam/system.cc, exposed for tests): the only
// writer of the map (STYLE.md 5). Per keyframe (ORB-SLAM's LocalMapping::Run):
//
// 1. insertion: observations of the tracked landmarks, their geometry, covisibility;
// 2. recent point culling: a point created two keyframes ago must have >= 3 observations;
// 3. new points: epipolar search (slam/match/epipolar_matcher.h) with the best covisible
//    keyframes, triangulation on bearings with parallax, positive depth, reprojection (chi^2 at
//    the keypoint's octave) and scale-consistency checks;
// 4. duplicate fusion: the new keyframe's points projected into its neighbours and back;
// 5. local BA (slam/optimize/bundle_adjustment.h): the keyframe and its covisibles free, the
//    other keyframes that see their points fixed; outlier observations removed;
// 6. redundant keyframe culling: a covisible keyframe whose points are >= 90% seen by >= 3 other
//    keyframes at the same or a finer scale is erased;
// 7. a new LocalMapSnapshot around the keyframe.
//
// Not thread-safe: called from one thread at a time (System's mapping thread, or inline).

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "slam/bow/bow_database.h"
#include "slam/data/local_map_snapshot.h"
#include "slam/data/slam_map.h"
#include "slam/match/epipolar_matcher.h"
#include "slam/module/initializer.h"
#include "slam/module/line_cloud_localizer.h"
#include "slam/module/line_cloud_relocalizer.h"
#include "slam/module/line_cloud_view_registration.h"
#include "slam/system_options.h"
#include "slam/system_stats.h"

namespace lcv::slam {

struct InitialMap {
  Id reference_keyframe_id = kInvalidId;
  Id current_keyframe_id = kInvalidId;
  Rigid3d current_cam_from_world;     // after BA and scale normalization (and registration)
  // The motion from the reference to the current frame in the map's final units (a
  // registration into a line cloud may have moved and rescaled the map), and the current
  // keyframe's SlamKeyframe::scale.
  Rigid3d current_from_reference;
  double current_keyframe_scale = 1.0;
  std::vector<Id> current_landmark_ids;  // per keypoint of the current frame
};

class LocalMapper {
 public:
  LocalMapper(const Camera& camera, const SystemOptions& options);

  // Builds the map from a two-view initialization (both frames prepared, reference at the
  // origin): two keyframes, the triangulated points, global BA, median depth scaled to 1.
  // Empty (and the map left empty) when the result is degenerate after BA.
  std::optional<InitialMap> Initialize(const Frame& reference, const Frame& current,
                                       const Initialization& initialization);

  // Runs steps 1-7 for a keyframe candidate (a tracked frame with pose and matches).
  void ProcessKeyframe(const Frame& frame);

  // Clears the map (every segment).
  void Reset();
  // Tracking was lost for good: keeps the active segment (and its database entries, for a later
  // merge by loop closing) as an inactive one and starts an empty segment to initialize in.
  void ArchiveActiveSegment();
  // Drops the active segment (a new map lost again before it grew), keeping inactive ones; the
  // same as Reset() when there are none.
  void DiscardActiveSegment();

  // Replaces the map by a loaded one (slam/data/slam_map_import.h): BoW vectors and database
  // entries for every keyframe, a snapshot around the newest keyframe. Returns that keyframe.
  Id LoadMap(SlamMap map);

  // ---- Line cloud (docs/slam.md "LC-VSLAM client"; slam/line_cloud_mapping.cc) ----
  // Starts from a server line cloud without client keyframes (lines, server keyframes and their
  // cameras): the client initializes on its own and registers into it later.
  void LoadLineCloud(SlamMap line_cloud);
  // After LoadMap or LoadLineCloud: where each line's hidden point can lie, the server
  // keyframes' BoW. Returns what makes the line cloud unusable or partly usable (empty when
  // nothing), for the user.
  std::string PrepareLineCloud();
  // Relocalization in the line cloud (slam/module/line_cloud_relocalizer.h) from a keyframe of
  // the active segment, when the segment is not registered yet. Called on every new keyframe.
  void TryRegisterInLineCloud(Id keyframe_id);
  // The p6L localizer of the loaded line cloud (owned by System, outlives the mapper; nullptr:
  // none), for the registration from the p6L poses of several keyframes when P4L / P3P fail
  // (slam/module/line_cloud_view_registration.h). Localize is const and reentrant: tracking's
  // line-cloud check uses the same one.
  void SetLineCloudLocalizer(const LineCloudLocalizer* localizer) {
    line_cloud_localizer_ = localizer;
  }
  // Marks the map detached from the line cloud or attached again after keyframe_id
  // (slam/module/line_cloud_loop.h, UpdateLineCloudDetachment), where line-cloud loops are
  // closed. Called on every new keyframe, before the snapshot is published.
  void UpdateLineCloudDetachment(Id keyframe_id);
  int line_cloud_detachments() const { return line_cloud_detachments_; }
  // X' released by LineCloudSettings::release_off_line_deg (restored_point_release.h).
  int restored_points_released() const { return restored_points_released_; }
  int line_cloud_attempts() const { return line_cloud_attempts_; }
  int line_cloud_registrations() const { return line_cloud_registrations_; }
  const LineCloudRelocalizationReport& last_line_cloud_report() const {
    return last_line_cloud_report_;
  }
  // One entry per attempt, the first SystemStats::kMaxLineCloudAttemptLog.
  const std::vector<SystemStats::LineCloudAttempt>& line_cloud_attempt_log() const {
    return line_cloud_attempt_log_;
  }

  // Publishes a snapshot around keyframe_id (relocalization: track the local map of the
  // keyframe the frame was found against) and returns it. The keyframe must exist.
  // lines_near: the line cloud's lines are those around this point instead of the keyframe's
  // (LocalMapSnapshotOptions::lines_near), until a snapshot around another keyframe is published.
  std::shared_ptr<const LocalMapSnapshot> PublishAround(
      Id keyframe_id, const std::optional<Eigen::Vector3d>& lines_near = std::nullopt);
  // Republishes the snapshot around its current reference keyframe (or the newest keyframe
  // when that one was erased) after the map changed outside ProcessKeyframe (loop correction,
  // global BA).
  void Republish();

  // For loop correction and global BA, which System runs on the same (writer) thread between
  // keyframes (docs/slam.md "Threads").
  SlamMap* mutable_map() { return &map_; }
  const BowDatabase& database() const { return database_; }
  // The server keyframes' BoW (line descriptors), for loop detection in the line cloud.
  const BowDatabase& server_database() const { return server_database_; }
  // Keyframe ids inserted since the last call (for loop detection), in insertion order; kept
  // only when options.LoopClosingActive().
  std::vector<Id> TakeNewKeyframeIds();

  // Restored points X' created from tracking's 2D point - 3D line matches so far.
  int num_restored() const { return num_restored_; }
  int num_local_ba_runs() const { return num_local_ba_runs_; }
  // Local BAs that should_stop ended before they converged (see SetLocalBundleStop).
  int num_local_ba_stopped_early() const { return num_local_ba_stopped_early_; }
  // Keyframe candidates whose pose was re-anchored because the map moved after they were tracked
  // (ReanchoredKeyframePose).
  int num_keyframes_reanchored() const { return num_keyframes_reanchored_; }
  // Polled between local BA iterations; true ends the BA with the state it reached
  // (BundleOptions::should_stop). System sets it for live input: stop when tracking has queued
  // the next keyframe (ORB-SLAM's InterruptBA, stella_vslam's abort_local_BA).
  void SetLocalBundleStop(std::function<bool()> should_stop) {
    local_ba_should_stop_ = std::move(should_stop);
  }
  double local_ba_ms() const { return local_ba_ms_; }

  // The latest snapshot (nullptr before initialization).
  std::shared_ptr<const LocalMapSnapshot> snapshot() const { return snapshot_; }
  const SlamMap& map() const { return map_; }

 private:
  void InsertKeyframe(const Frame& frame, Id keyframe_id);
  // The keyframe's p6L pose joins the views of its segment; registers the segment from them
  // when they agree (see SetLineCloudLocalizer).
  void TryRegisterFromViews(Id keyframe_id);
  // The X' of the line a keypoint of the frame was matched to (created on the line when it has
  // none); kInvalidId when the active segment is not registered.
  Id RestoreLinePoint(const Frame& frame, int keypoint_index, Id keyframe_id);
  void CullRecentLandmarks(Id keyframe_id);
  // New points between the keyframe and its best covisible keyframes, and the keyframe its frame
  // was tracked against (Frame::reference_keyframe_id) when that is not among them: a frame
  // posed by tracking's two-view step shares few map points with any keyframe.
  int TriangulateNewLandmarks(Id keyframe_id, Id reference_keyframe_id);
  int FuseDuplicates(Id keyframe_id);
  // Projects landmarks into a keyframe and merges/links them. Returns the number fused.
  int FuseInto(const std::vector<Id>& landmark_ids, Id keyframe_id);
  void RunLocalBundleAdjustment(Id keyframe_id);
  // The mapping state of the active segment (new keyframes, snapshot, recent points).
  void ClearActiveSegmentState();
  void RunGlobalBundleAdjustment(int iterations);
  int CullRedundantKeyframes(Id keyframe_id);
  void Publish(Id keyframe_id);

  // BoW vector and direct index of a keyframe's descriptors (no-op without a vocabulary).
  void ComputeBow(SlamKeyframe* keyframe) const;
  void AddToDatabase(Id keyframe_id);

  const Camera& camera_;
  SystemOptions options_;
  SlamMap map_;
  BowDatabase database_;
  std::vector<Id> new_keyframe_ids_;
  int num_local_ba_runs_ = 0;
  int num_local_ba_stopped_early_ = 0;
  int num_keyframes_reanchored_ = 0;
  std::function<bool()> local_ba_should_stop_;
  int num_restored_ = 0;
  // Hidden points lie within this many times the 95th percentile of the server keyframes'
  // perpendicular distances to their lines (bounds the discretized lines on cameras without an
  // image border, equirectangular).
  static constexpr double kLineDistanceFactor = 3.0;
  // Local BA leaves the gauge to the lines when at least this many X' are in the problem (each
  // constrains two directions; 20 keep a 7-dof similarity well determined with margin).
  static constexpr int kMinRestoredForLineGauge = 20;
  // A client point seen at a p6L inlier of a view registration becomes X' when the registration
  // puts it within this many times p6L's inlier angle of its line (as seen from the keyframe).
  static constexpr double kRestoreFromViewsMaxAngleFactor = 3.0;
  BowDatabase server_database_;
  std::map<Id, std::unique_ptr<Camera>> server_cameras_;
  int line_cloud_attempts_ = 0;
  int line_cloud_registrations_ = 0;
  int line_cloud_detachments_ = 0;  // times the map was marked detached
  int restored_points_released_ = 0;
  int low_restored_streak_ = 0;     // see UpdateLineCloudDetachment
  LineCloudRelocalizationReport last_line_cloud_report_;
  const LineCloudLocalizer* line_cloud_localizer_ = nullptr;
  std::vector<LineCloudView> line_cloud_views_;  // of segment line_cloud_views_segment_
  int line_cloud_views_segment_ = -1;
  int line_cloud_view_localizations_ = 0;  // p6L runs in that segment
  std::vector<SystemStats::LineCloudAttempt> line_cloud_attempt_log_;
  double local_ba_ms_ = 0.0;
  EpipolarMatchOptions epipolar_options_;
  std::shared_ptr<const LocalMapSnapshot> snapshot_;
  std::uint64_t snapshot_version_ = 0;
  // PublishAround's lines_near and the keyframe it was given with (Republish keeps it).
  std::optional<Eigen::Vector3d> lines_near_;
  Id lines_near_keyframe_id_ = kInvalidId;
  std::uint64_t keyframe_counter_ = 0;
  // Points created recently, with the keyframe counter at their creation.
  std::vector<std::pair<Id, std::uint64_t>> recent_landmarks_;
  std::vector<int> window_;
};

}  // namespace lcv::slam
