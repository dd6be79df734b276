#pragma once
// The SLAM engine behind one facade: monocular tracking (constant-velocity prediction,
// projection matching, motion-only BA, local-map tracking, keyframe decision) and local mapping
// (keyframe insertion, point culling, triangulation, local BA, keyframe culling).
//
// Threads (STYLE.md 5): TrackImage runs tracking on the caller's thread. Local mapping runs on
// its own thread, is the only writer of the map, and republishes an immutable LocalMapSnapshot
// after each keyframe; tracking reads the latest snapshot and queues keyframe candidates through
// a bounded queue. In deterministic mode (options.deterministic) there is no mapping thread:
// each keyframe is mapped inline before TrackImage returns, so a run is reproducible bit for bit.
//
// Inputs are images; the engine reads no files (apps wire mapping/io to it).
// Thread safety: one thread calls TrackImage/Finish; the accessors may be called from that
// thread after Finish().

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "slam/camera/camera.h"
#include "slam/data/map.h"
#include "slam/feature/keypoint.h"
#include "slam/geometry/rigid3.h"
#include "slam/module/initializer.h"
#include "slam/match/line_projection_matcher.h"
#include "slam/module/keyframe_policy.h"
#include "slam/module/line_cloud_loop.h"
#include "slam/module/line_cloud_relocalizer.h"
#include "slam/util/ids.h"

namespace cv {
class Mat;
}

namespace lcv::slam {

class Vocabulary;  // slam/bow/vocabulary.h

struct FeatureSettings {
  int num_features = 2000;     // per image; see DefaultNumFeatures for other resolutions
  double scale_factor = 1.2;
  int num_levels = 8;
  int ini_fast_threshold = 20;
  int min_fast_threshold = 7;
};

// A feature budget for a camera: 2000 for KITTI's 1241x376 (ORB-SLAM's setting), scaled with
// the pixel count and clamped to [1000, 2000] (1000 at 640x360, where it keeps tracking within
// ~13 ms with the same accuracy on the synthetic sequences). An equirectangular image spreads
// its pixels over the whole sphere (4 pi sr against ~2 sr for a 90 deg perspective view), so it
// gets twice the budget, clamped to [2000, 4000]: with 1000 features on 640x320 the local map
// was too sparse to re-establish tracking after a one-second interruption (docs/slam.md).
int DefaultNumFeatures(CameraModel model, int cols, int rows);

struct TrackingSettings {
  float motion_search_radius_px = 15.f;  // window for matching the last frame's landmarks
  float local_map_radius_factor = 1.f;   // ORB-SLAM's th for the local map search
  int min_motion_matches = 20;           // below this the search is widened
  int min_tracked_inliers = 30;          // a relocalized frame with fewer inliers is lost
  int min_recovered_inliers = 20;        // the same for a pose found around the predicted one
  int lost_after_frames = 5;             // consecutive lost frames before re-initialization
  // With relocalization: a map of more than 5 keyframes is kept and relocalized in for this
  // long (seconds of input) before it is given up and re-initialized (ORB-SLAM3's 3 s for
  // monocular; the map given up is kept for a later merge, LoopClosingSettings::merge_maps).
  double max_lost_seconds = 3.0;
  // After a gap (lost or missing frames) the constant velocity is extrapolated over at most
  // this long (the camera is assumed to stop there).
  double max_extrapolation_seconds = 3.0;
  // When the extrapolated rotation exceeds this, the recovery search also tries half and none
  // of it (Tracker::RecoverPose).
  double recovery_rotation_hypothesis_rad = 0.09;  // ~5 deg
  double max_view_angle_deg = 60.0;      // vs a landmark's mean viewing direction
};

struct MappingSettings {
  int max_triangulation_neighbours = 10;  // covisible keyframes searched for new points
  int local_ba_iterations = 10;
  int max_local_ba_keyframes = 10;        // optimized keyframes (neighbours of the new one)
  double min_parallax_deg = 1.0;           // new point triangulation
  double redundant_keyframe_ratio = 0.9;   // culling: share of points seen by >= 3 others
  bool fuse_duplicates = true;
  bool cull_keyframes = true;
  int keyframe_queue_capacity = 1;
};

struct RelocalizationSettings {
  bool enabled = true;          // needs a vocabulary
  int max_candidates = 10;      // BoW candidates tried per lost frame
  int min_inliers = 50;         // after motion-only BA (ORB-SLAM's threshold)
};

struct LoopClosingSettings {
  bool enabled = true;                 // needs a vocabulary
  // A map lost for good (max_lost_seconds, more than 5 keyframes) is kept as an inactive
  // segment instead of being dropped, and a loop between the new map and it merges the two
  // (ORB-SLAM3's atlas and map merging, within one SlamMap; see slam/data/slam_map.h). Until
  // then trajectory, keyframes and exported map are the active segment's.
  bool merge_maps = true;
  bool global_bundle_adjustment = true;  // after each loop correction (background thread)
  int global_ba_iterations = 10;
};

// The LC-VSLAM client in a server's line cloud (docs/slam.md "LC-VSLAM client").
struct LineCloudSettings {
  LineCloudRelocalizerOptions relocalizer;  // registration of the client's map (Sec. 3.2)
  LineMatchOptions matching;                // 2D point - 3D line search in tracking (Sec. 3.3)
  bool match_lines = true;                  // false: track only X and X' (for comparison)
  // Past this many client keyframes without registration the user is told (stderr, stats).
  int warn_after_keyframes = 20;
  // Loop closing against the line cloud (slam/module/line_cloud_loop.h), when loop closing
  // runs: a client that left the line cloud and returns is corrected onto it.
  bool close_loops = true;
  LineCloudLoopOptions loop;
  // Global BA after a loop in a registered map frees the lines and server keyframes (eq. 9);
  // false keeps them fixed (the client map alone moves).
  bool global_ba_frees_line_cloud = true;
  // Omega_vL of the virtual observations: false the paper's constant, true propagated from
  // Omega_L (GlobalBAOptions::derived_virtual_information).
  bool derived_virtual_information = false;
};

struct SystemOptions {
  FeatureSettings features;
  InitializerOptions initializer;
  TrackingSettings tracking;
  MappingSettings mapping;
  KeyframePolicyOptions keyframe_policy;
  RelocalizationSettings relocalization;
  LoopClosingSettings loop_closing;
  LineCloudSettings line_cloud;
  // The BoW vocabulary of relocalization and loop closing (slam/bow); both are off without one.
  std::shared_ptr<const Vocabulary> vocabulary;
  // Track in the map given to LoadMap without changing it: no keyframes, no new points, no loop
  // closing; frames that cannot be tracked relocalize.
  bool localization_only = false;
  bool deterministic = false;  // map (and close loops) inline on the caller's thread
  std::uint64_t seed = 1;

  // Loop closing runs: enabled, a non-empty vocabulary, and not localization-only.
  bool LoopClosingActive() const;
};

// What the engine did, for the stats file.
struct LoopEvent {
  Id query_keyframe_id = kInvalidId;
  Id match_keyframe_id = kInvalidId;
  double timestamp = 0.0;  // of the query keyframe
  bool closed = false;     // corrected (detected loops may be rejected by the corrector)
  bool merged_maps = false;  // the match was in another segment, now merged into its map
  int num_matches = 0;
  // Closed against the server's line cloud (match_keyframe_id: the client keyframe the
  // loop edge links to, num_matches: registration inliers).
  bool line_cloud = false;
};

struct SystemStats {
  int loops_detected = 0;
  int loops_closed = 0;
  int relocalizations = 0;
  int local_ba_runs = 0;
  double local_ba_ms = 0.0;  // total
  int pose_graph_runs = 0;
  double pose_graph_ms = 0.0;
  int global_ba_runs = 0;
  double global_ba_ms = 0.0;
  // LC-VSLAM client (a line cloud was loaded): registration attempts (one per keyframe until
  // it succeeds), whether and at which keyframe timestamp the client map was registered, X'
  // restored so far (at registration and by local mapping), and what the user must know about
  // the line cloud (empty when nothing).
  bool line_cloud = false;
  int line_cloud_attempts = 0;
  bool relocalized_in_line_cloud = false;
  double line_cloud_registration_timestamp = 0.0;
  std::string line_cloud_method;  // "p4l" or "p3p" of the registration
  int line_cloud_inliers = 0;
  double line_cloud_scale = 0.0;  // server_from_client scale
  double line_cloud_registration_ms = 0.0;
  int restored_points = 0;        // X' in the exported map's segment
  std::string line_cloud_problem;
  std::string line_cloud_last_failure;  // of the last failed registration attempt
  int maps_kept = 0;    // lost maps kept as inactive segments (LoopClosingSettings::merge_maps)
  int maps_merged = 0;  // of those, merged back by a loop
  std::vector<LoopEvent> loops;
};

enum class TrackingState { kInitializing, kTracking, kLost };
const char* TrackingStateName(TrackingState state);  // "initializing", "tracking", "lost"

struct FrameResult {
  Id frame_id = kInvalidId;
  double timestamp = 0.0;
  TrackingState state = TrackingState::kInitializing;
  std::optional<Rigid3d> cam_from_world;  // when tracked (or just initialized)
  int num_keypoints = 0;
  int num_matches = 0;  // inlier landmark matches after pose optimization
  // Of those, the e_pL terms: keypoints matched to an X' or to a line of the line cloud.
  int num_line_matches = 0;
  bool is_keyframe = false;  // handed to mapping as a keyframe (or initial keyframe)
  bool relocalized = false;  // pose found by relocalization (BoW + PnP) in this frame
  double extraction_ms = 0.0;  // feature extraction part of tracking_ms
  double tracking_ms = 0.0;    // whole TrackImage call minus mapping_ms
  // Deterministic mode: inline mapping time; threaded mode: time spent waiting for room in the
  // keyframe queue (mapping falling behind). Both include a (re)initialization's map building.
  double mapping_ms = 0.0;
};

struct TimedPose {
  Id id = kInvalidId;
  double timestamp = 0.0;
  Rigid3d cam_from_world;
};

class System {
 public:
  // camera: the camera of every image. Precondition: !camera.Problem().
  System(const CameraParams& camera, const SystemOptions& options);
  ~System();
  System(const System&) = delete;
  System& operator=(const System&) = delete;

  // Before the first frame: starts from a saved map (keyframes with keypoints and descriptors,
  // points with observations) instead of initializing; the first frames relocalize in it.
  // Without options.localization_only the map is extended. Throws std::invalid_argument naming
  // the problem when the map cannot be used (no keyframes, keyframes without descriptors, a
  // camera unlike this system's).
  void LoadMap(const Map& map);

  // Tracks one image (8-bit gray or BGR, camera size), timestamp in seconds, increasing. mask:
  // empty or 8-bit, non-zero where features may be detected.
  FrameResult TrackImage(const cv::Mat& image, double timestamp);
  FrameResult TrackImage(const cv::Mat& image, const cv::Mat& mask, double timestamp);

  // Tracks pre-extracted features (keypoints in raw image pixels with octave and angle, one
  // descriptor each), bypassing the ORB extractor: for synthetic tests and external front ends.
  FrameResult TrackFeatures(std::vector<Keypoint> keypoints, std::vector<OrbDescriptor> descriptors,
                            double timestamp);

  // Drains the keyframe queue and stops the mapping thread. Further TrackImage calls are
  // invalid.
  void Finish();

  // After Finish(): every tracked frame's pose, re-anchored to its reference keyframe's final
  // pose (so it reflects local BA), in frame order.
  std::vector<TimedPose> FrameTrajectory() const;
  // After Finish(): keyframe poses, by id.
  std::vector<TimedPose> KeyframeTrajectory() const;
  // After Finish(): the map as the persistent model (one camera, id 0).
  Map ExportMap() const;
  int NumKeyframes() const;
  int NumLandmarks() const;
  // How many times the map was (re)initialized.
  int NumInitializations() const;
  // Counters so far (safe to call between TrackImage calls and after Finish).
  SystemStats Stats() const;

  const Camera& camera() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lcv::slam
