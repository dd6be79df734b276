#pragma once
// The tracking stage of System (internal to slam/system.cc, exposed for tests): given a prepared
// frame and the latest LocalMapSnapshot it estimates the frame's pose (ORB-SLAM's Track):
//
// 1. prediction: constant velocity, pose = velocity * last pose (the last frame re-anchored to
//    its reference keyframe's current pose, so local BA corrections carry over); after a gap
//    (lost or missing frames) the velocity is extrapolated over the elapsed time (on SE(3), up
//    to max_extrapolation_seconds), so that tracking can resume where a camera moving on
//    would be (a vehicle does not stop when its camera is covered);
// 2. motion-model matching: the last frame's landmarks projected into the frame (window
//    motion_search_radius_px * octave scale, orientation check), widened once when too few;
//    motion-only BA (slam/optimize, rounds with outlier rejection);
// 3. recovery when that gives fewer than min_motion_matches inliers (ChooseAfterWeakMotion):
//    all local-map landmarks projected with a wide window, P3P RANSAC on bearings
//    (slam/solve/absolute_pose.h), motion-only BA; when that is weak too, the last frame's
//    landmarks (and the window's in its view) matched by descriptor alone (no window) and P3P,
//    the centre within 2 frame intervals' travel; the best of these and the weak
//    motion-model pose by local-map inliers. Before it, when the last frame became the reference
//    keyframe, step 2 is repeated with the landmarks local mapping triangulated from it
//    (AdoptReferenceLandmarks); when all of that and relocalization (5) fail right after a
//    tracked frame, the two-view step (TrackByTwoView): the pose relative to the last frame
//    from their 2D-2D matches, for a turn faster than the map can follow;
// 4. local-map tracking: landmarks of the snapshot's window in view of the predicted pose
//    (frustum, viewing angle, scale range) projected at their predicted octave; motion-only BA;
// 5. relocalization when 2-3 fail (or the tracker is lost): inline (deterministic mode) the
//    caller's RelocalizeFunction (BoW + PnP in the whole map) gives a pose and a snapshot around
//    the keyframe it was found against, and step 4 runs against that snapshot; with the
//    threads the frame is handed over (TrackingOutput::relocalization_request), the map's
//    writer relocalizes it while tracking goes on, and OnRelocalized takes the result: the
//    relocalized frame becomes the last frame, and the next frames are tracked from it;
// 6. state: tracking with >= min_recovered_inliers inliers (min_tracked_inliers after a
//    relocalization), else lost; keyframe decision
//    (slam/module/keyframe_policy.h; a frame after a tracked one whose pose step 2 did not
//    give becomes a keyframe at once, a two-view pose whatever it tracks: local mapping
//    triangulates its points with the keyframe it was tracked against). A lost tracker asks for a reset after lost_after_frames
//    frames without relocalization, or with relocalization while the map has <= 5 keyframes
//    (ORB-SLAM) or after max_lost_seconds; never when the map was loaded, except for a camera
//    that has not tracked in the loaded map yet (OnMapLoaded's may_start_own_map).
//
// Before the map exists, frames go to the Initializer; a successful two-view initialization is
// returned to the caller, who builds the map (local mapping owns it) and calls OnInitialized.
// Until then (with the threads the map is built on the mapping thread while frames keep
// coming) frames are kept and posed against the new map afterwards.
// The initialization's motion is the first velocity; the frames seen while initializing are
// posed against the new map on the next frame and added to records() (PoseInitializationFrames).
//
// Never touches the map: it reads snapshots only (STYLE.md 5). Not thread-safe: one tracking
// thread.

#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "slam/data/frame.h"
#include "slam/data/local_map_snapshot.h"
#include "slam/match/line_projection_matcher.h"
#include "slam/match/line_search_backoff.h"
#include "slam/match/projection_matcher.h"
#include "slam/module/initializer.h"
#include "slam/optimize/motion_only_ba.h"
#include "slam/frame_result.h"
#include "slam/system_options.h"

namespace lcv::slam {

// What the tracker asks of its caller after a frame.
struct TrackingOutput {
  FrameResult result;
  // Set when the frame should become a keyframe: the frame with its pose and inlier matches.
  std::optional<Frame> keyframe_candidate;
  // Set when two-view initialization succeeded: build the map from these two frames.
  struct InitializationRequest {
    Frame reference;
    Frame current;
    Initialization initialization;
  };
  std::optional<InitializationRequest> initialization;
  // Set when tracking was lost for too long: the caller resets the map.
  bool request_reset = false;
  // The pose came from relocalization (the caller counts it).
  bool relocalized = false;
  // The line-cloud check ran on the frame, and refused its pose (the caller counts both).
  bool line_cloud_checked = false;
  bool line_cloud_check_refused = false;
  // ... or replaced it by the pose tracked from p6L's (Tracker::TrackFromLineCloudPose).
  bool line_cloud_check_adopted = false;
  // ... and its time budget ended its search (live mode).
  bool line_cloud_check_cut_short = false;
  // Localization-only mode: the landmarks the frame tracked (inliers), so that the caller can
  // move the local-map window along with the camera (no keyframes move it in this mode).
  std::vector<Id> tracked_landmark_ids;
  // Asynchronous relocalization (EnableAsyncRelocalization): the lost frame (prepared, without
  // matches) to relocalize in the whole map; the answer comes back through OnRelocalized.
  std::optional<Frame> relocalization_request;
};

// An independent localization of a frame in a registered line cloud (System: p6L on the whole
// line cloud), given the frame with its tracked pose.
struct LineCloudPoseCheckResult {
  Rigid3d cam_from_world;
  int num_inliers = 0;
  int num_agreeing = 0;  // of those inlier matches, the ones that also fit the frame's pose
};
struct LineCloudPoseCheckOutcome {
  std::optional<LineCloudPoseCheckResult> located;  // nullopt when it found no pose
  bool cut_short = false;  // the time budget ended the search (live mode)
};
// time_budget_s > 0: stop the search after about that many seconds and answer with what was
// found by then (live mode, TrackingSettings::line_cloud_check_live_periods); <= 0: no limit.
using LineCloudPoseCheck =
    std::function<LineCloudPoseCheckOutcome(const Frame&, double time_budget_s)>;

// The rule of the check (TrackingSettings::line_cloud_check_*): true when the independent
// localization has enough inliers and disagrees with the tracked pose both in its matches (too
// few fit the tracked pose) and in its pose (further than the share of median_depth, or turned
// by more than the angle). median_depth <= 0: the distance test is skipped.
// The check's time budget in seconds for the frames of a camera whose smallest frame interval so
// far is min_frame_interval_s (0: not known yet, 0.1 s assumed): 0 (no limit) unless the input
// is live (TrackingSettings::line_cloud_check_live_periods).
double LineCloudCheckTimeBudget(const SystemOptions& options, double min_frame_interval_s);

// The checks still owed after one (TrackingSettings::line_cloud_check_live_retries =
// max_retries): none once a check answered (it was not cut short, or found a confident pose
// anyway); an unanswered first check owes max_retries, an unanswered retry one fewer than before.
int LineCloudCheckRetriesLeft(int retries_left, bool was_retry, bool unanswered, int max_retries);

bool LineCloudCheckRefuses(const LineCloudPoseCheckResult& check,
                           const Rigid3d& tracked_cam_from_world, double median_depth,
                           const TrackingSettings& settings);

// Relocalization, provided by the caller (System: BoW candidates + PnP in the whole map, under
// the map's lock): given a prepared frame, sets frame->cam_from_world and its inlier matches and
// returns a snapshot around the keyframe the frame was found against; nullptr on failure (then
// the frame's matches are cleared).
using RelocalizeFunction = std::function<std::shared_ptr<const LocalMapSnapshot>(Frame*)>;

// A tracked frame's pose relative to the keyframe it was tracked against, for the final
// trajectory (re-anchored to the keyframe's optimized pose).
struct FrameRecord {
  Id frame_id = kInvalidId;
  double timestamp = 0.0;
  Id reference_keyframe_id = kInvalidId;
  Rigid3d frame_from_reference;
  double reference_scale = 1.0;  // the reference's SlamKeyframe::scale (slam/data/frame_anchor.h)
  Rigid3d cam_from_world;  // at tracking time
};

class Tracker {
 public:
  Tracker(const SystemOptions& options);

  // Tracks a prepared frame (PrepareFrame) against snapshot (nullptr before initialization).
  // mapping_idle: local mapping would accept a keyframe now.
  TrackingOutput Track(Frame frame, const LocalMapSnapshot* snapshot, bool mapping_idle);

  // The map was built from the last initialization request: the current frame is now at
  // cam_from_world with these landmark ids per keypoint, and is keyframe current_keyframe_id.
  // current_from_reference: the motion over the initialization's span (the first velocity);
  // keyframe_scale: the current keyframe's SlamKeyframe::scale.
  void OnInitialized(const Rigid3d& cam_from_world, const std::vector<Id>& landmark_ids,
                     Id current_keyframe_id, const Rigid3d& current_from_reference,
                     double keyframe_scale);
  // The map was reset (or the initial map failed): start initializing again.
  // keep_records: the frames tracked so far stay in records() (their map was kept, SlamMap
  // segments).
  void Reset(bool keep_records = false);

  // Enables relocalization: lost frames (and frames the motion model cannot track) call it.
  void SetRelocalizer(RelocalizeFunction relocalize) { relocalize_ = std::move(relocalize); }
  // Enables the line-cloud check of recovered, collapsed and resumed frames in a registered line
  // cloud (TrackingSettings::line_cloud_check_*; System sets it unless line_cloud_check_agreement
  // is 0).
  void SetLineCloudPoseCheck(LineCloudPoseCheck check) {
    line_cloud_pose_check_ = std::move(check);
  }
  // Enables relocalization without waiting for it: such frames are returned as
  // TrackingOutput::relocalization_request (the frame itself counts as lost).
  void EnableAsyncRelocalization() { async_relocalization_ = true; }
  // The answer to a relocalization_request: `frame` (an earlier frame, with pose, reference
  // keyframe and inlier matches set by slam/module/relocalizer.h) was relocalized against
  // snapshot's keyframes. Ignored unless the tracker is still lost. Records the frame; the next
  // frame is predicted from it (no velocity). Returns whether it was taken.
  bool OnRelocalized(Frame frame, const LocalMapSnapshot& snapshot);
  // The keyframe candidate of the last Track call was not taken (live mode, mapping behind):
  // the next frames may propose again, as if it had not been proposed.
  void OnKeyframeRefused();
  // At the end of a run: poses the frames an initialization waited through (normally done on
  // the next frame) when the map arrived after the last frame (threaded live mode).
  void PosePendingInitializationFrames(const LocalMapSnapshot& snapshot) {
    if (initialization_frames_pending_) PoseInitializationFrames(snapshot);
  }
  // Forgets the records of frames before first_kept_frame_id (their map was dropped by a reset
  // the writer carried out after the tracker was already reset).
  void DropRecordsBefore(Id first_kept_frame_id);
  // A saved map was loaded: the next frames relocalize in it instead of initializing. With
  // localization_only no keyframes are proposed. The map is never reset (it is the user's),
  // except that with may_start_own_map a camera that has not tracked a frame in it and is still
  // lost after max_lost_seconds (TrackingSettings::start_outside_loaded_map) asks for a reset:
  // the caller keeps the loaded map and starts a new one beside it.
  void OnMapLoaded(bool localization_only, bool may_start_own_map = false);

  TrackingState state() const { return state_; }
  // Records of the frames tracked in the current map (cleared by Reset).
  const std::vector<FrameRecord>& records() const { return records_; }

 private:
  // Re-anchors last_frame_ to the snapshot's pose of its reference keyframe.
  void ReanchorLastFrame(const LocalMapSnapshot& snapshot);
  // When the last frame became the snapshot's reference keyframe, takes that keyframe's
  // landmarks per keypoint (LocalMapSnapshot::reference_landmark_ids): the points local mapping
  // triangulated from it. Returns whether that added any. Called when the motion model is weak
  // (the motion-model search is repeated with them, and the window-free recovery uses them):
  // in a sharp turn those new points are most of what the next frame can still see (ORB-SLAM
  // reaches them through its reference keyframe's map points). Not on every frame: searching
  // the fresh two-view points by motion model on every frame doubled the APE of the 400-frame
  // perspective loops (seed 1: 0.209 -> 0.457 m, seed 2: 0.182 -> 0.350 m).
  bool AdoptReferenceLandmarks(const LocalMapSnapshot& snapshot);
  // The constant-velocity prediction for a frame at `timestamp` (see step 1).
  Rigid3d PredictPose(double timestamp) const;
  int MatchLastFrame(const LocalMapSnapshot& snapshot, float radius_factor, Frame* frame);
  // Step 2: MatchLastFrame, widened once below min_motion_matches, then OptimizePose from the
  // frame's pose. Returns the inliers (0 below min_motion_matches matches).
  int TrackLastFrame(const LocalMapSnapshot& snapshot, Frame* frame);
  // Local-map landmarks projected into the frame. wide: the recovery search (4x window, viewing
  // angle up to 90 deg, scale range x[0.5, 2]): after a gap the camera sees the map from
  // further along, at angles and distances the normal gates would reject.
  int MatchLocalMap(const LocalMapSnapshot& snapshot, Frame* frame, bool wide = false);
  // Returns the inliers of the best hypothesis (success from 10; -1 when none was scored); the
  // frame keeps that hypothesis's pose and matches.
  int RecoverPose(const LocalMapSnapshot& snapshot, const Rigid3d& predicted, Frame* frame);
  // After a motion-model stage with fewer than min_motion_matches inliers (motion_pose_ok: it
  // still gave a pose, >= 10 inliers, which the frame holds): the best of that pose,
  // RecoverPose's and, when both track fewer than min_recovered_inliers,
  // TrackLastFrameByAppearance's, each scored by the inliers of the local-map search at its
  // pose. The frame keeps the winner's pose and matches.
  struct WeakMotionChoice {
    int score = -1;             // local-map inliers of the winner (success from 10)
    bool motion_model = false;  // the winner is the motion model's pose
  };
  WeakMotionChoice ChooseAfterWeakMotion(const LocalMapSnapshot& snapshot, const Rigid3d& predicted,
                                         bool motion_pose_ok, Frame* frame);
  // Prediction-free recovery (slam/tracking_appearance.cc): the last frame's landmarks and the
  // window's landmarks its camera had in view matched into the frame by descriptor alone (no
  // window), then PoseFromMatches. Returns its inliers (0 without a P3P consensus). The caller
  // checks the result's travel (TrackingSettings::window_free_max_travel).
  int TrackLastFrameByAppearance(const LocalMapSnapshot& snapshot, Frame* frame);
  // The two-view step may run: enabled, not localization-only, a posed last frame and a
  // velocity (its travel scales the step when the map cannot).
  // ORB-SLAM's pause of keyframes after a relocalization (about a second, in a map of more
  // than max_frames keyframes), unless the frame is further than the keyframe policy's travel
  // from the snapshot's reference keyframe: a place the map does not cover yet.
  bool PauseKeyframesAfterRelocalization(const LocalMapSnapshot& snapshot,
                                         const Rigid3d& cam_from_world) const;
  bool TwoViewAllowed() const;
  // The two-view step (slam/tracking_two_view.cc), for a frame that nothing else found right
  // after a tracked frame: last frame and frame matched by descriptor alone
  // (slam/match/frame_matcher.h), the essential matrix by RANSAC on their bearings
  // (EstimateTwoViewGeometry with TrackingSettings' gates), its translation scaled by the median
  // depth ratio of the last frame's map points among the triangulated pairs (at least 5), else
  // by the last interval's travel; rejected beyond window_free_max_travel times that travel.
  // At the pose, the local-map search: with >= min_recovered_inliers matches motion-only BA
  // refines it as for any frame, else the pose stays and the matches that reproject within
  // chi^2 (2 dof) at their octave are kept. Returns those map inliers (may be 0: the 2D-2D
  // geometry is the evidence), -1 on failure (the frame's pose and matches are then undefined:
  // the caller treats the frame as lost). Precondition: TwoViewAllowed().
  int TrackByTwoView(const LocalMapSnapshot& snapshot, Frame* frame);
  // P3P RANSAC on the frame's landmark matches, then motion-only BA. Returns the inliers of the
  // motion-only BA (0 when P3P found no consensus); on success the frame keeps its pose and
  // inlier matches.
  int PoseFromMatches(const LocalMapSnapshot& snapshot, Frame* frame);
  // 2D point - 3D line matching (slam/match/line_projection_matcher.h) of the snapshot's lines
  // whose X' is not matched yet; matched keypoints take the line's id. Returns new matches.
  // backoff: the frame's own search, which skips and counts lines by line_search_backoff_ (not
  // a second search of the same frame from another pose).
  int MatchLocalLines(const LocalMapSnapshot& snapshot, Frame* frame, bool backoff = true);
  // Motion-only BA (eq. 6) on the frame's matches: e_pP for points, e_pL for X' and for
  // keypoints matched to lines; removes outliers from the frame. Returns inliers.
  int OptimizePose(const LocalMapSnapshot& snapshot, Frame* frame);
  // The line-cloud check's other use: local-map tracking again from p6L's pose (when it is
  // confident and somewhere else), kept when it tracks more inliers than the frame's pose did
  // (then *frame and *inliers are replaced and true is returned; otherwise nothing changes).
  bool TrackFromLineCloudPose(const LocalMapSnapshot& snapshot,
                              const LineCloudPoseCheckResult& check, Frame* frame, int* inliers);

  // Retroactive posing of the initialization's frames (slam/tracking_initialization.cc).
  // While initializing: keeps the frames seen since initializing began (the newest 60).
  void BufferInitializationFrame(const Frame& frame);
  // After initialization, with the new map's first snapshot: poses the buffered frames between
  // the reference and the current keyframe (interpolated pose, wide then normal local-map
  // search, motion-only BA) and records them with the reference frame, so that the trajectory
  // starts at the reference frame instead of the frame that completed the initialization.
  void PoseInitializationFrames(const LocalMapSnapshot& snapshot);

  SystemOptions options_;
  Initializer initializer_;
  MotionOnlyBA motion_only_ba_;
  TrackingState state_ = TrackingState::kInitializing;

  Frame last_frame_;
  bool has_last_frame_ = false;
  // The last frame was posed by the two-view step and tracked no map point, and how many frames
  // in a row up to the last one the step posed (TwoViewAllowed).
  bool last_frame_two_view_without_map_ = false;
  int consecutive_two_view_frames_ = 0;
  // Live: frames still to check after a check cut short without a confident pose.
  int line_cloud_check_retries_left_ = 0;
  // OnRelocalized took a frame without matches (relocalized in the line cloud on the writer):
  // the next frame searches the local map from its pose instead of following its matches.
  bool track_local_map_from_last_pose_ = false;
  Rigid3d last_frame_from_reference_;
  double last_frame_reference_scale_ = 1.0;
  std::optional<Rigid3d> velocity_;  // current_from_last of the last tracked pair
  double velocity_dt_ = 0.0;          // seconds between that pair's frames
  double initialization_reference_timestamp_ = 0.0;  // of the last initialization's reference
  Id initialization_reference_id_ = kInvalidId;
  // Frames seen while initializing (BufferInitializationFrame), posed by
  // PoseInitializationFrames on the first frame after a successful initialization.
  std::vector<Frame> initialization_frames_;
  bool initialization_frames_pending_ = false;
  int frames_since_keyframe_ = 0;
  int frames_since_keyframe_before_candidate_ = 0;  // restored by OnKeyframeRefused
  int consecutive_lost_ = 0;
  double last_tracked_timestamp_ = 0.0;
  // The smallest positive interval between consecutive frames seen (the camera's frame period;
  // dropped frames only lengthen intervals), 0 before the second frame.
  double min_frame_interval_s_ = 0.0;
  std::optional<double> last_seen_timestamp_;  // of the last frame Track was given
  RelocalizeFunction relocalize_;
  LineCloudPoseCheck line_cloud_pose_check_;
  int last_num_inliers_ = 0;  // of the last tracked frame
  bool map_loaded_ = false;
  bool localization_only_ = false;
  // OnMapLoaded's may_start_own_map; whether a frame was tracked in the loaded map; the first
  // frame's timestamp after the load (the start of the loss of a camera that starts outside).
  bool may_start_own_map_ = false;
  bool tracked_in_loaded_map_ = false;
  std::optional<double> loaded_map_first_timestamp_;
  bool async_relocalization_ = false;
  // An initialization was handed over and its map is not built yet: frames are kept.
  bool awaiting_map_ = false;
  std::vector<FrameRecord> records_;

  // Buffers reused frame to frame (STYLE.md 8).
  ProjectionMatchScratch match_scratch_;
  std::vector<ProjectionCandidate> candidates_;
  std::vector<MotionOnlyPointTerm> point_terms_;
  std::vector<MotionOnlyLineTerm> line_terms_;
  std::vector<int> term_keypoints_;
  std::vector<int> line_term_keypoints_;
  std::vector<LineMatchCandidate> line_candidates_;
  LineMatchScratch line_scratch_;
  std::vector<LineMatch> line_matches_;
  LineSearchBackoff line_search_backoff_;
  int lines_searched_ = 0;    // this frame: lines searched (FrameResult::num_lines_searched)
  int lines_backed_off_ = 0;  // ... and lines the back-off skipped
  std::vector<char> line_term_is_map_point_;  // an X' (else a line without X')
  std::vector<char> point_term_is_restored_;  // an X' tracked as a fixed point
  // X' (as line or point terms) and lines kept by the last OptimizePose
  int last_num_line_inliers_ = 0;
  int last_num_new_line_inliers_ = 0;  // of those, lines without an X'
  bool line_cloud_tracking_ = false;  // the snapshot carries lines
};

}  // namespace lcv::slam
