#pragma once
// What tracking sees of the map (STYLE.md 5): an immutable copy of the local window around the
// newest keyframe, republished by local mapping after each keyframe insertion and local BA and
// handed to tracking as shared_ptr<const LocalMapSnapshot>. Tracking never locks or writes the
// map; a snapshot is read-only once published and may be read from any thread.

#include <cstdint>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "slam/data/slam_map.h"
#include "slam/feature/keypoint.h"
#include "slam/geometry/line3.h"
#include "slam/geometry/rigid3.h"
#include "slam/util/ids.h"

namespace lcv::slam {

struct SnapshotLandmark {
  Id id = kInvalidId;
  Eigen::Vector3d position_in_world = Eigen::Vector3d::Zero();
  OrbDescriptor descriptor{};
  Eigen::Vector3d mean_viewing_direction = Eigen::Vector3d::UnitZ();
  double min_distance = 0.0;
  double max_distance = 0.0;
  int num_observations = 0;
  Id line_id = kInvalidId;  // an X' (SlamLandmark::line_id): its line is in LocalMapSnapshot::lines
};

// A server line near the window (registered segments only; docs/slam.md "LC-VSLAM client").
struct SnapshotLine {
  Id id = kInvalidId;
  Line3d line;
  Eigen::Matrix3d sqrt_information = Eigen::Matrix3d::Zero();  // of Omega_L
  bool has_descriptor = false;
  OrbDescriptor descriptor{};
  bool has_interval = false;  // SlamLine::has_interval; lines without one are not searched
  double s_min = 0.0;
  double s_max = 0.0;
  Id restored_landmark_id = kInvalidId;  // its X', when restored
  // Centroid of the centres of the server keyframes that saw the line (world frame), for the
  // matcher's viewing test (LineMatchCandidate); has_viewers false when none is in the map.
  bool has_viewers = false;
  Eigen::Vector3d viewers_centroid = Eigen::Vector3d::Zero();
};

struct SnapshotKeyframe {
  Id id = kInvalidId;
  double timestamp = 0.0;
  Rigid3d cam_from_world;
  double scale = 1.0;  // SlamKeyframe::scale
};

struct LocalMapSnapshot {
  std::uint64_t version = 0;          // increases with every publication
  Id reference_keyframe_id = kInvalidId;  // the newest keyframe, centre of the window
  // Landmarks of the reference keyframe with >= 3 observations (>= 2 while the map has at most 2
  // keyframes): the keyframe policy's reference count.
  int reference_num_tracked = 0;
  // Restored points X' the reference keyframe observes (LC-VSLAM; 0 outside a line cloud): the
  // keyframe policy's count for a client leaving the cloud (KeyframePolicyOptions::
  // line_cloud_fading_ratio).
  int reference_num_restored = 0;
  // Median distance from the reference keyframe's centre to its landmarks (X and X'); 0 when it
  // has none. The keyframe policy's travel test (KeyframePolicyOptions::max_travel_of_depth).
  double reference_median_distance = 0.0;
  int map_num_keyframes = 0;  // of the active segment (SlamMap::active_segment)
  // The reference keyframe's source frame (SlamKeyframe::source_frame_id) and its landmark per
  // keypoint (kInvalidId where none), including the points local mapping triangulated or fused
  // after tracking proposed it: the tracker's copy of that frame lacks them
  // (Tracker::AdoptReferenceLandmarks).
  Id reference_source_frame_id = kInvalidId;
  std::vector<Id> reference_landmark_ids;
  int map_num_landmarks = 0;

  // The window: the reference keyframe, its covisible keyframes and their best neighbours,
  // sorted by id; and every landmark they observe, sorted by id.
  std::vector<SnapshotKeyframe> keyframes;
  std::vector<SnapshotLandmark> landmarks;
  // landmarks[i].id, for FindLandmark: tracking looks up every match (a few thousand per frame),
  // and a binary search over 8-byte ids stays in cache where one over the landmarks does not.
  // Filled with landmarks (MakeLocalMapSnapshot); when its size differs, FindLandmark searches
  // landmarks itself.
  std::vector<Id> landmark_ids;

  // Poses of every keyframe of the map, sorted by id (for re-anchoring frames).
  std::vector<SnapshotKeyframe> all_keyframes;

  // The window's segment is in the line cloud's frame (SlamMap::registered_segment): lines holds
  // the lines seen by the server keyframes nearest to the reference keyframe (not while the map
  // is detached from the line cloud, SlamMap::LineCloudDetached) and the lines of the window's
  // X', sorted by id. Empty otherwise.
  bool registered = false;
  std::vector<SnapshotLine> lines;

  // Binary searches; nullptr when absent.
  const SnapshotLine* FindLine(Id id) const;
  const SnapshotLandmark* FindLandmark(Id id) const;
  const SnapshotKeyframe* FindKeyframe(Id id) const;  // searches all_keyframes
};

struct LocalMapSnapshotOptions {
  int max_covisible_keyframes = 20;  // first ring of the window
  int max_second_ring_per_keyframe = 5;
  int max_window_keyframes = 60;
  // Server keyframes (nearest centres to the reference keyframe's) whose lines are in the
  // snapshot. The engine passes LineCloudSettings::snapshot_server_keyframes.
  int max_server_keyframes = 10;
  // Where those server keyframes are sought (world frame); empty: around the reference
  // keyframe's centre. A frame relocalized in the line cloud far from every client keyframe
  // needs the lines around itself (docs/slam.md "A lost frame relocalized in the line cloud").
  std::optional<Eigen::Vector3d> lines_near;
};

// Builds the snapshot around reference_keyframe_id (which must exist in map).
LocalMapSnapshot MakeLocalMapSnapshot(const SlamMap& map, Id reference_keyframe_id,
                                      const LocalMapSnapshotOptions& options,
                                      std::uint64_t version);

}  // namespace lcv::slam
