#pragma once
// The SLAM-side map: keyframes and point landmarks with the runtime indices the engine needs
// beyond the persistent model of slam/data/map.h: per-keypoint landmark ids, landmark
// observations, the covisibility graph and spanning tree, per-landmark mean viewing direction and
// scale-invariance distances. Converted to slam::Map for saving (ToMap).
//
// Thread safety: none inside (STYLE.md 5). Local mapping is the only writer; tracking never sees
// a SlamMap, only immutable LocalMapSnapshots (slam/data/local_map_snapshot.h) built from it.
//
// Ids: keyframes and landmarks share one counter, so ids are unique map-wide (slam::Map's rule).

#include <map>
#include <memory>
#include <optional>
#include <set>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "slam/bow/bow_vector.h"
#include "slam/camera/camera.h"
#include "slam/data/frame.h"
#include "slam/data/map.h"
#include "slam/feature/keypoint.h"
#include "slam/geometry/line3.h"
#include "slam/geometry/rigid3.h"
#include "slam/geometry/sim3.h"
#include "slam/util/ids.h"
#include "slam/util/shared_vector.h"

namespace lcv::slam {

struct SlamKeyframe {
  Id id = kInvalidId;
  Id source_frame_id = kInvalidId;  // the Frame it was made from
  double timestamp = 0.0;
  const Camera* camera = nullptr;  // not owned
  ScaleLevels scale_levels;
  Rigid3d cam_from_world;
  // Length, in today's map units, of what was one unit around this keyframe when it was made:
  // a Sim(3) correction of scale s (loop closing) multiplies it by 1/s. Rigid offsets recorded
  // against the keyframe (tracked frames, erased keyframes) are rescaled by the ratio of
  // today's value to the value they were recorded at (AnchoredFramePose).
  double scale = 1.0;
  // The map segment it belongs to (SlamMap::StartSegment).
  int segment = 0;
  // Read from a map file (--map-in), not made by this run (MappingSettings::hold_loaded_keyframes).
  bool loaded = false;
  // Made while its segment was registered in a line cloud and attached to it (not detached,
  // SlamMap::LineCloudDetached): tracked against the lines and held by them in local BA, not
  // drifting on its own. Runtime only (not in map files). A line-cloud loop's pose graph may
  // hold such keyframes fixed (LineCloudLoopOptions::hold_keyframes_made_in_line_cloud).
  bool made_in_line_cloud = false;

  // The features never change once the keyframe is made: they are SharedVectors (and the grid
  // shares its arrays), so that copies of the map (the loop-closing stage's, after every
  // keyframe) share them instead of copying ~100 KB per keyframe (slam/util/shared_vector.h).
  SharedVector<Keypoint> keypoints;
  SharedVector<OrbDescriptor> descriptors;
  SharedVector<Eigen::Vector3d> bearings;  // unit, camera frame
  KeypointGrid grid;
  std::vector<Id> landmark_ids;  // per keypoint; kInvalidId when none

  // Bag of words and direct index of the descriptors (empty without a vocabulary): filled by
  // local mapping on insertion, used by relocalization and loop detection.
  SharedVector<BowEntry> bow;
  SharedVector<DirectIndexEntry> direct_index;

  // Covisibility: keyframe id -> number of shared landmarks (only entries with weight >= the
  // graph's threshold, or the single strongest one), and the same sorted by decreasing weight
  // (ties by id, for determinism).
  std::map<Id, int> covisibility_weights;
  std::vector<std::pair<Id, int>> ordered_covisibles;

  // Spanning tree: parent is the most covisible older keyframe (none for the first).
  Id parent_id = kInvalidId;
  std::vector<Id> child_ids;

  Eigen::Vector3d Center() const { return cam_from_world.Center(); }
  int NumLandmarks() const;
  // The keyframe policy's reference counts, in one pass over the keyframe's landmarks: points X
  // (not X') with at least min_observations observations, and restored points X'.
  struct LandmarkCounts {
    int well_observed_points = 0;
    int restored = 0;
  };
  LandmarkCounts CountLandmarks(const class SlamMap& map, int min_observations) const;
  // Median distance from the centre to the keyframe's landmarks (X and X'); 0 when it has none.
  double MedianLandmarkDistance(const class SlamMap& map) const;
};

struct SlamLandmark {
  Id id = kInvalidId;
  Eigen::Vector3d position_in_world = Eigen::Vector3d::Zero();
  OrbDescriptor descriptor{};  // the observation descriptor with least median distance to others
  std::vector<Observation> observations;
  // Unit mean of the directions camera centre -> point over the observing keyframes (world).
  Eigen::Vector3d mean_viewing_direction = Eigen::Vector3d::UnitZ();
  // Scale-invariance range (ORB-SLAM): distances at which the point can be detected at the
  // pyramid's top and bottom levels.
  double min_distance = 0.0;
  double max_distance = 0.0;
  Id first_keyframe_id = kInvalidId;      // the keyframe that created it
  Id reference_keyframe_id = kInvalidId;  // the keyframe its distances are measured from
  int segment = 0;                        // that of the keyframe that created it
  // X' (paper Sec. 3.1): the server line this point was restored on, kInvalidId for a point X
  // reconstructed from 2D observations only. Bundle adjustments add the line term e_pL for it.
  Id line_id = kInvalidId;
  int NumObservations() const { return static_cast<int>(observations.size()); }
  bool IsRestored() const { return line_id != kInvalidId; }
};

// A line L of the server's line cloud (always in the server's frame; fixed in part 1 of the
// client: tracking, local BA and the rigid-stereo BA do not move it).
struct SlamLine {
  Id id = kInvalidId;
  Line3d line;
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();       // Omega_L (eq. 1)
  Eigen::Matrix3d sqrt_information = Eigen::Matrix3d::Zero();  // SqrtInformation(Omega_L)
  std::optional<OrbDescriptor> descriptor;  // lines without one cannot be matched
  std::vector<Id> server_keyframe_ids;
  // Where on the line its hidden point can lie: parameters along line.direction from the anchor
  // (in front of and inside the image of every server keyframe that sees it; LineVisibleInterval).
  // has_interval false: unknown (no usable server keyframe), the line is not searched by tracking.
  bool has_interval = false;
  double s_min = 0.0;
  double s_max = 0.0;
  Id restored_landmark_id = kInvalidId;  // the X' restored on it (a SlamLandmark), if any
  // The line as it was loaded (the published L0 of the paper's virtual observations v), kept
  // while bundle adjustments move `line` (LineCloudBundleOptions::virtual_from_published).
  Line3d published_line;
  // Where the line is held to be: as loaded, then as each applied global BA leaves it (local
  // BA's moves are not kept here). ReleaseRestoredPointsOffTheirLines measures X' against it.
  Line3d reference_line;

  // Moves `line` to `moved` (unit direction) with Omega_L (and its square root, which tracking's
  // e_pL uses) turned by the smallest rotation from the old direction to the new one.
  void MoveTo(const Line3d& moved);
};

// A server keyframe P_ks: pose, camera and the lines it sees; no keypoints.
struct SlamServerKeyframe {
  Id id = kInvalidId;
  Id camera_id = kInvalidId;  // in SlamMap::server_cameras()
  double timestamp = 0.0;
  Rigid3d cam_from_world;
  Rigid3d published_cam_from_world;  // as loaded (see SlamLine::published_line)
  std::vector<Id> line_ids;
  // BoW vector and direct index of the descriptors of its lines, in line_ids order (lines
  // without a descriptor are skipped; descriptor_line_ids lists the lines the indices refer to).
  BowVector bow;
  DirectIndex direct_index;
  std::vector<Id> descriptor_line_ids;
};

class SlamMap {
 public:
  // Keyframe pairs sharing at least this many landmarks are covisibility neighbours.
  static constexpr int kCovisibilityThreshold = 15;

  SlamMap() = default;

  // A fresh id for a keyframe or landmark.
  Id NewId() { return next_id_++; }

  // Adds a keyframe made from a frame (copies features, pose, grid). Its landmark ids are NOT
  // adopted: call AddObservation for the matches (they may refer to culled landmarks).
  SlamKeyframe& AddKeyframe(const Frame& frame);
  // Adds a landmark at position_in_world, created by keyframe first_keyframe_id (which must exist),
  // with no observations yet.
  SlamLandmark& AddLandmark(const Eigen::Vector3d& position_in_world, Id first_keyframe_id);

  // Map import (slam_map_import.h): inserts with a given id, which must be valid and unused
  // (checked); later NewId() calls return larger ids. The keyframe is empty apart from its id
  // (the caller fills features, pose, grid and sizes landmark_ids); it becomes the first keyframe
  // when the map has none yet or its id is smaller than the current first one's (so importing in
  // any order anchors the gauge on the smallest id). The landmark is as AddLandmark makes it.
  SlamKeyframe& AddKeyframeWithId(Id id);
  SlamLandmark& AddLandmarkWithId(Id id, const Eigen::Vector3d& position_in_world,
                                  Id first_keyframe_id);
  // Makes NewId() return ids >= next_free_id from now on (never lowers the counter).
  void ReserveIdsBelow(Id next_free_id);

  // Links keypoint keypoint_index of a keyframe to a landmark (both must exist). A keypoint
  // already linked to another landmark is unlinked from it first. Returns false (and does
  // nothing) when the landmark is already observed by that keyframe.
  bool AddObservation(Id landmark_id, Id keyframe_id, int keypoint_index);
  // Unlinks the landmark from that keyframe. Erases the landmark when fewer than
  // min_remaining_observations remain.
  void RemoveObservation(Id landmark_id, Id keyframe_id, int min_remaining_observations = 2);
  // Erases a landmark and all its links (an X' is unlinked from its line).
  void EraseLandmark(Id landmark_id);
  // Moves every observation of landmark `from` onto `into` (duplicate fusion) and erases `from`.
  // Observations by a keyframe that already sees `into` are dropped. When `from` is an X' and
  // `into` is not restored, `into` takes over its line (it becomes the line's X').
  void ReplaceLandmark(Id from, Id into);
  // Erases a keyframe: unlinks its observations (landmarks left with < 2 observations go too),
  // reattaches its children in the spanning tree, updates covisibility. Never erase the first
  // keyframe (checked).
  void EraseKeyframe(Id keyframe_id);

  // Recomputes mean viewing direction, scale-invariance range and representative descriptor.
  void UpdateLandmarkGeometry(Id landmark_id);
  // Recomputes the covisibility edges of a keyframe (both sides) and, if it has none, its parent.
  void UpdateCovisibility(Id keyframe_id);

  // Recomputes the covisibility of every keyframe and the spanning tree from scratch, with the
  // result UpdateCovisibility called on each keyframe in id order gives on a map without edges
  // or parents (the tree local mapping builds when keyframes arrive in id order), in one pass
  // over the observations instead of one per keyframe. For map import.
  void RebuildCovisibility();

  // Up to max_count neighbours by decreasing covisibility weight.
  std::vector<Id> CovisibleKeyframes(Id keyframe_id, int max_count) const;

  const SlamKeyframe* FindKeyframe(Id id) const;
  SlamKeyframe* FindKeyframe(Id id);
  const SlamLandmark* FindLandmark(Id id) const;
  SlamLandmark* FindLandmark(Id id);

  const std::map<Id, SlamKeyframe>& keyframes() const { return keyframes_; }
  const std::map<Id, SlamLandmark>& landmarks() const { return landmarks_; }
  std::map<Id, SlamKeyframe>& mutable_keyframes() { return keyframes_; }
  std::map<Id, SlamLandmark>& mutable_landmarks() { return landmarks_; }
  // The first keyframe of the active segment (the gauge anchor of its optimizations).
  Id first_keyframe_id() const { return first_keyframe_id_; }

  // Segments (ORB-SLAM3's atlas within one map): when tracking is lost for good, the map it was
  // lost in is kept as an inactive segment and a new one is started in its own frame and scale.
  // Keyframes and landmarks are added to the active segment. Segments share no landmarks, so
  // covisibility, the spanning tree, local mapping and the local map of tracking never cross
  // them; a loop between two segments merges them (MoveSegment). Everything that iterates over
  // the whole map must filter by segment (global BA, pose graph, export).
  int active_segment() const { return active_segment_; }
  // Starts a new, empty active segment; returns its number.
  int StartSegment();
  int NumKeyframesInSegment(int segment) const;
  // Erases a segment's keyframes, landmarks and erased-keyframe records (no re-anchoring).
  void EraseSegment(int segment);
  // Moves segment `from` into segment `to`'s frame by to_world_from_from_world (a similarity:
  // keyframe poses, landmark positions and distances, erased-keyframe offsets, scales) and
  // relabels it `to`. When `from` was active, `to` becomes active.
  void MoveSegment(int from, int to, const Sim3d& to_world_from_from_world);

  // Loop edges of the essential graph (loop closing): pairs (query keyframe, matched keyframe),
  // kept for later pose-graph optimizations. Keyframes with a loop edge are never culled
  // (HasLoopEdge).
  void AddLoopEdge(Id a, Id b) { loop_edges_.emplace_back(a, b); }
  const std::vector<std::pair<Id, Id>>& loop_edges() const { return loop_edges_; }
  bool HasLoopEdge(Id keyframe_id) const;

  // ---- The server's line cloud (paper Sec. 3; docs/slam.md "LC-VSLAM client") ----
  // Lines and server keyframes keep their ids (which must be unused; checked). The cameras of
  // the server keyframes are kept by id for export.
  SlamLine& AddLineWithId(Id id);
  SlamServerKeyframe& AddServerKeyframeWithId(Id id);
  void AddServerCamera(Id camera_id, const CameraParams& params) { server_cameras_[camera_id] = params; }
  const SlamLine* FindLine(Id id) const;
  SlamLine* FindLine(Id id);
  const SlamServerKeyframe* FindServerKeyframe(Id id) const;
  const std::map<Id, SlamLine>& lines() const { return lines_; }
  std::map<Id, SlamLine>& mutable_lines() { return lines_; }
  const std::map<Id, SlamServerKeyframe>& server_keyframes() const { return server_keyframes_; }
  std::map<Id, SlamServerKeyframe>& mutable_server_keyframes() { return server_keyframes_; }
  const std::map<Id, CameraParams>& server_cameras() const { return server_cameras_; }
  bool HasLineCloud() const { return !lines_.empty(); }
  // Clears every client keyframe, landmark, segment and loop edge, keeping the line cloud (lines
  // without X', server keyframes and cameras): a reset of the client never drops the server's
  // map. Ids keep counting up.
  void ClearClientData();
  // Makes landmark_id the X' of line_id (both must exist; the line must have no other X' and the
  // landmark no other line, checked).
  void RestoreOnLine(Id landmark_id, Id line_id);
  // Makes an X' an ordinary point again (its line forgets it). No-op for a point.
  void ReleaseFromLine(Id landmark_id);
  // The segment that is in the line cloud's frame (registered by relocalization in the line
  // cloud, or loaded with it), -1 when none.
  int registered_segment() const { return registered_segment_; }
  bool ActiveSegmentRegistered() const { return registered_segment_ == active_segment_; }
  void SetRegisteredSegment(int segment) {
    registered_segment_ = segment;
    line_cloud_detached_ = false;
    if (segment >= 0) segments_in_line_cloud_frame_.insert(segment);
  }
  // Every segment that was registered and is still in the line cloud's frame: the active one
  // and those kept after a loss (System's ResetMap keeps a registered segment whatever its
  // size). Their keyframes and frames share the server's frame, so the trajectories join them.
  bool SegmentInLineCloudFrame(int segment) const {
    return segments_in_line_cloud_frame_.count(segment) > 0;
  }
  // The registered client has left the line cloud (docs/slam.md "Leaving and re-entering the
  // line cloud"; UpdateLineCloudDetachment, slam/module/line_cloud_loop.h): snapshots carry no
  // server keyframe's lines, so tracking does not pull a drifted client back onto them, and the
  // return is left to loop closing, whose correction attaches the client again. Written by the
  // map's writer.
  bool LineCloudDetached() const { return line_cloud_detached_; }
  void SetLineCloudDetached(bool detached) { line_cloud_detached_ = detached; }

  // The persistent model of the active segment: one camera (id camera_id), keyframes with
  // keypoints and descriptors,
  // point landmarks with observations and descriptor. Covariance is set to the identity scaled
  // by (depth * pixel angle)^2 as a rough isotropic uncertainty. With a line cloud: every line
  // (an X' of the active segment as its restored_point with its observations), every server
  // keyframe, and the server cameras under their ids (the client camera then takes camera_id
  // unless a server camera uses that id with other parameters: then the next free id).
  // `segment`: the segment to write instead of the active one (-1), e.g. a loaded map that the
  // run's own map never joined (SegmentWithLoadedKeyframes).
  Map ToMap(const CameraParams& camera_params, Id camera_id = 0, int segment = -1) const;
  // The segment holding keyframes read from a map file (SlamKeyframe::loaded), -1 if none.
  int SegmentWithLoadedKeyframes() const;
  // The segment a run's outputs hold (trajectories, map file, counts; docs/slam.md "Which
  // segment the outputs hold"): the active one when it is registered in the line cloud or
  // holds the loaded map; else one in the line cloud's frame; else the one with the most
  // keyframes of the run's own (not loaded), the active one on a tie (ORB-SLAM3 saves its
  // biggest map).
  int OutputSegment() const;

  // Scales the active segment about the world origin (scale normalization): points, keyframe
  // centres, scale-invariance distances. scale > 0.
  void Transform(double scale);

  // Erased keyframes, for re-anchoring frames tracked against them: erased id -> (the keyframe
  // that replaced it as anchor, pose of the erased keyframe relative to it,
  // erased_cam_from_anchor_cam). Follow the chain until a living keyframe.
  struct ErasedKeyframe {
    int segment = 0;
    Id anchor_id = kInvalidId;
    Rigid3d erased_from_anchor;
    double erased_scale = 1.0;  // SlamKeyframe::scale of both keyframes when it was erased
    double anchor_scale = 1.0;
  };
  const std::map<Id, ErasedKeyframe>& erased_keyframes() const { return erased_keyframes_; }

 private:
  bool IdInUse(Id id) const;
  // Clears the line's X' link when it points to this landmark.
  void UnlinkRestored(const SlamLandmark& landmark);

  std::map<Id, SlamKeyframe> keyframes_;
  std::map<Id, SlamLandmark> landmarks_;
  std::map<Id, ErasedKeyframe> erased_keyframes_;
  std::map<Id, SlamLine> lines_;
  std::map<Id, SlamServerKeyframe> server_keyframes_;
  std::map<Id, CameraParams> server_cameras_;
  int registered_segment_ = -1;
  std::set<int> segments_in_line_cloud_frame_;
  bool line_cloud_detached_ = false;
  std::vector<std::pair<Id, Id>> loop_edges_;
  Id next_id_ = 1;
  Id first_keyframe_id_ = kInvalidId;
  int active_segment_ = 0;
  int num_segments_ = 1;
};

}  // namespace lcv::slam
