#pragma once
// Settings of the SLAM engine's stages (slam/system.h), apart from the engine so that the stages
// (slam/tracking.h, slam/local_mapping.h, slam/loop_closing.h) include only what they configure.
// Plain values with defaults; units in the comments. lcv slam reads them from --config
// (apps/slam_config.h; docs/slam.md lists the keys).

#include <cstdint>
#include <memory>

#include "slam/camera/camera.h"
#include "slam/match/line_projection_matcher.h"
#include "slam/match/line_search_backoff.h"
#include "slam/module/initializer.h"
#include "slam/module/keyframe_policy.h"
#include "slam/module/line_cloud_loop.h"
#include "slam/module/line_cloud_relocalizer.h"
#include "slam/module/line_cloud_view_registration.h"

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
  // A camera that has not tracked a frame in a loaded map (--map-in) and is still lost after
  // max_lost_seconds from its first frame starts a map of its own, which loop closing merges
  // into the loaded one when the camera gets there (ORB-SLAM3 with a loaded atlas; needs loop
  // closing with merge_maps, never with --localization-only). false: it stays lost until it
  // relocalizes in the loaded map (stella_vslam). docs/slam.md "A camera that starts outside a
  // loaded map".
  bool start_outside_loaded_map = true;
  // After a gap (lost or missing frames) the constant velocity is extrapolated over at most
  // this long (the camera is assumed to stop there).
  double max_extrapolation_seconds = 3.0;
  // When the extrapolated rotation exceeds this, the recovery search also tries half and none
  // of it (Tracker::RecoverPose).
  double recovery_rotation_hypothesis_rad = 0.09;  // ~5 deg
  double max_view_angle_deg = 60.0;      // vs a landmark's mean viewing direction
  // Threads of the searches by projection (last frame, local map; ProjectionMatchOptions::
  // num_threads): the tracking thread and search_threads - 1 helpers. The matches do not depend
  // on it. Measured in docs/benchmarks-lcvslam.md ("Point searches on two threads").
  int search_threads = 2;
  // The window-free recovery (Tracker::TrackLastFrameByAppearance) when the motion model and the
  // wide search both fail: any rotation, but the camera centre within window_free_max_travel
  // times the last frame interval's travel (scaled to the elapsed time) of the last frame's; a
  // camera found further away (kidnapped) is left to relocalization and its stricter test.
  bool window_free_recovery = true;
  double window_free_max_travel = 2.0;
  // In a registered line cloud, a pose the motion model could not give (the recovery search
  // after a gap found it), one tracked with fewer than line_cloud_check_collapse of the last
  // frame's inliers, or the first one tracked after lost frames, is checked against p6L on the
  // whole line cloud (the independent per-frame localization of
  // slam/module/line_cloud_localizer.h). The camera is judged to be
  // somewhere else when p6L localizes the frame with at least line_cloud_check_min_inliers
  // inliers, fewer than line_cloud_check_agreement of those keypoint-line matches fit the
  // recovered pose too (bearing within twice p6L's threshold of the line's plane), and p6L's pose
  // is more than line_cloud_check_depth_fraction of the snapshot's median scene depth or
  // line_cloud_check_max_deg away: then the frame is lost and the map restarts at once (a
  // registered map is kept; the new one registers again). 0 agreement disables the check.
  // Why: after a jump of the camera, the recovery search found 53 "inliers" among X' and lines
  // at a pose 8 m off, none on a point, and tracking went on from there (docs/slam.md
  // "Interruptions in a line cloud"). Both tests, because each alone was close to the line on
  // the cases measured: at that wrong pose 34 of p6L's 68 inliers fit, p6L 8.5 m away (median
  // depth 22.5 m); at correct recovered poses 67 of 68, 40 of 61 (fisheye: p6L's own pose 2.0 m
  // and 5 degrees off, median depth 10.9 m) and 136 of 136.
  double line_cloud_check_agreement = 0.75;
  // Equirectangular s1 after the jump: 95 inliers at the wrong pose, 656 on the frame before.
  double line_cloud_check_collapse = 0.25;
  double line_cloud_check_depth_fraction = 0.25;
  double line_cloud_check_max_deg = 10.0;
  int line_cloud_check_min_inliers = 30;
  // Live input (SystemOptions::live) only: the check's time budget in frame periods (the
  // smallest interval between frames seen; 0.1 s before two frames), 0: none. The check runs on
  // the tracking thread, and p6L on a frame with a low inlier ratio samples up to its cap (1.5-3
  // ms a sample): live, single frames took up to 3.5 s and dropped up to 44 frames. So live, the
  // check first searches the camera centre with the tracked orientation held (microseconds a
  // sample; LineCloudLocalizer::Localize's rotation_prior) and p6L gets what is left of the
  // budget. Measured on 12 interrupted sequences, two live runs each (docs/slam.md "The
  // line-cloud check on a live camera"): no frame dropped and every run in the server frame
  // (before: 10 runs dropped frames, 5 lost the registered map); three periods dropped frames
  // for no gain.
  double line_cloud_check_live_periods = 1.0;
  // Live: after a check that its budget cut short before it found a pose of
  // line_cloud_check_min_inliers, the next tracked frames are checked too, each within its own
  // budget and with other samples, until one check answers or this many were tried.
  int line_cloud_check_live_retries = 4;
  // Before the rule above, local-map tracking runs again from p6L's pose and replaces the
  // frame's when it tracks more inliers (a wrong recovered pose keeps fewer of the map's points
  // than the right one), unless the two poses are within these of each other. Measured on the
  // 36 interruption runs (docs/slam.md "Tracking again from p6L's pose"): recovered poses 1.8-3.4
  // m off with p6L 0.01-0.22 m off passed the refusal's rule; re-tracked, 8 runs above 1 m -> 0.
  double line_cloud_retrack_min_depth_fraction = 0.02;
  double line_cloud_retrack_min_deg = 1.0;
  // The two-view step (Tracker::TrackByTwoView) when those fail too right after a tracked
  // frame: the relative pose to the last frame from their 2D-2D matches (essential matrix on
  // bearings, slam/solve/two_view.h), scaled by the map points both see or else by the last
  // interval's travel (at most window_free_max_travel times it), and the frame becomes a keyframe
  // whose points local mapping triangulates with the keyframe tracked against. For a turn
  // faster than the map can follow (docs/slam.md "Sharp turns"). Its gates are the
  // initializer's relaxed: the map exists, and the pose is needed once, not a new map's scale.
  bool two_view_recovery = true;
  int two_view_min_points = 30;  // pairs, and points triangulated with the chosen motion
  int two_view_max_consecutive = 2;  // frames in a row (Tracker::TwoViewAllowed)
  int two_view_parallax_rank = 20;       // this many points with at least
  double two_view_parallax_deg = 0.5;    // this parallax
  double two_view_min_triangulated_ratio = 0.7;  // of the inliers, in front and reprojecting
};

struct MappingSettings {
  int max_triangulation_neighbours = 10;  // covisible keyframes searched for new points
  int local_ba_iterations = 10;
  // Optimized keyframes: the new one and its best covisible neighbours. ORB-SLAM and stella_vslam
  // take every covisible keyframe; the bound keeps a slow or hovering camera's local BA small.
  // 10 -> 20 cut KITTI 00's scale drift over its first 160 frames (APE 0.449 -> 0.402 m, local BA
  // 50 -> 71 ms per keyframe); synthetic loops within +-1% (docs/slam.md "Local BA window").
  int max_local_ba_keyframes = 20;
  // Keyframes read from a map file (--map-in) stay fixed in local BA: they anchor the client's
  // windows instead of being pulled along with its keyframes, as the server keyframes of a line
  // cloud already are. Measured (docs/slam.md "Local BA in a loaded map"): free, a client's
  // local BAs shrank a map on its ground-truth poses by up to 0.5 m over 60 m (APE 0.2-0.77 m,
  // held 0.04-0.16 m); KITTI 00 even frames in the odd frames' map 0.41 -> 0.28 m RMSE.
  bool hold_loaded_keyframes = true;
  // Local mapping uses the keypoints of the keyframes read from a map file: it triangulates new
  // points between a new keyframe and a loaded one and fuses landmarks into loaded keyframes,
  // so that the server's exactly posed views observe the client's own points. A line cloud
  // carries no keypoints (its server keyframes hold only the ids of the lines they saw), so a
  // line client never has them. false gives a point-map client the same information about its
  // own points as a line client, for comparing the two maps on what the points themselves add.
  // Measured (docs/benchmarks-lcvslam.md "The server's keypoints"): on tracking pairs inside
  // ground-truth maps, 88% of the perspective point client's own points are observed by loaded
  // keyframes; without them its APE rises 2.4x, to the line client's.
  bool use_loaded_keypoints = true;
  double min_parallax_deg = 1.0;           // new point triangulation
  double redundant_keyframe_ratio = 0.9;   // culling: share of points seen by >= 3 others
  bool fuse_duplicates = true;
  bool cull_keyframes = true;
  int keyframe_queue_capacity = 1;
};

struct RelocalizationSettings {
  bool enabled = true;          // BoW in the own keyframes needs a vocabulary; in_line_cloud not
  int max_candidates = 10;      // BoW candidates tried per lost frame
  int min_inliers = 50;         // after motion-only BA (ORB-SLAM's threshold)
  // A lost frame of a map registered in a line cloud, where the client's own keyframes do not
  // find it: p6L in the line cloud (docs/slam.md "A lost frame relocalized in the line cloud").
  // Its samples (1.5-3 ms each) are capped: a frame p6L cannot localize costs at most this many
  // (300 find an all-inlier sample of 6 with 99% probability at an inlier ratio of 0.5).
  // Live input (SystemOptions::live), the search runs on the map's writer, which maps the
  // keyframes meanwhile: line_cloud_live_max_trials p6L samples (30: 45-90 ms) per lost frame,
  // other samples on each next lost frame; the orientation-prior search before them costs
  // microseconds a sample (slam/solve/p3l_known_rotation.h).
  bool in_line_cloud = true;
  int line_cloud_max_trials = 300;
  int line_cloud_live_max_trials = 30;
  int line_cloud_min_inliers = 30;  // p6L inliers (as Tracking.line_cloud_check_min_inliers)
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
  // A loop in a loaded map (--map-in with keyframes) may reshape it but not move, turn or scale
  // it as a whole: after the essential graph and after global BA the map is moved back by the
  // similarity that fits its loaded keyframes' centres onto where they were (LoopCloserOptions::
  // keep_loaded_datum). Off, the correction spread over the loaded part displaces the map's frame
  // (docs/slam.md "Loops in a loaded map").
  bool keep_loaded_datum = true;
};

// The LC-VSLAM client in a server's line cloud (docs/slam.md "LC-VSLAM client").
struct LineCloudSettings {
  LineCloudRelocalizerOptions relocalizer;  // registration of the client's map (Sec. 3.2)
  // When P4L / P3P fail: registration from the p6L poses of several keyframes of the segment
  // (slam/module/line_cloud_view_registration.h).
  LineCloudViewRegistrationOptions view_registration;
  LineMatchOptions matching;                // 2D point - 3D line search in tracking (Sec. 3.3)
  bool match_lines = true;                  // false: track only X and X' (for comparison)
  // Motion-only BA (eq. 6) takes an X' observed by at least this many client keyframes as a
  // fixed 3D point (e_pP), like the client's own points; a younger X' stays free along its line
  // (e_pL, the paper's eq. 6). 0: every X' free, as in the paper. Why: a free X' holds the pose
  // only across its line, so the position along the line that the client's keyframes have
  // triangulated (and local BA refined) is thrown away each frame; where the cloud fades, the
  // X' are the last anchors placed by the cloud and the forward cameras lost scale there
  // (docs/benchmarks-lcvslam.md "Established X' as points in tracking": 27 overlap pairs x 3
  // runs 0.209 -> 0.201 m, 60-frame pairs 0.401 -> 0.336 m, ground-truth maps 0.149 -> 0.108 m).
  int track_restored_as_points_min_observations = 2;
  // The lines of this many server keyframes (nearest to the reference keyframe) are in each
  // tracking snapshot (LocalMapSnapshotOptions::max_server_keyframes). Measured 2026-11-27
  // (docs/benchmarks-lcvslam.md "Fewer server keyframes in the snapshot"): 6 instead of 10
  // keeps 95-100% of the line matches, cuts the equirectangular clients' local-map stage by
  // 0.5-0.75 ms (the line search), and the APE of the 12 overlap clients is no worse.
  int snapshot_server_keyframes = 6;
  // Lines that tracking searched in vain on several frames in a row are searched less often
  // (slam/match/line_search_backoff.h; off by default, on for an equirectangular camera in
  // `lcv slam`; measured in docs/benchmarks-lcvslam.md "Line search back-off").
  LineSearchBackoffOptions line_search_backoff;
  // Past this many client keyframes without registration the user is told (stderr, stats).
  int warn_after_keyframes = 20;
  // Loop closing against the line cloud (slam/module/line_cloud_loop.h), when loop closing
  // runs: a client that left the line cloud and returns is corrected onto it.
  bool close_loops = true;
  LineCloudLoopOptions loop;
  // Global BA after a loop in a registered map frees the lines and server keyframes (eq. 9);
  // false keeps them fixed (the client map alone moves).
  bool global_ba_frees_line_cloud = true;
  // ... and the server keyframes P_ks too (the paper's eq. 9; default true); false keeps them
  // fixed (see CaptureGlobalBA for what was measured).
  bool global_ba_frees_server_keyframes = true;
  // ... moving the result so that the freed server keyframes keep, in the least-squares sense,
  // the centroid, orientation and scale they had (the server map's datum; default true; false:
  // the two server keyframes seeing the fewest X' lines hold it, measured worse).
  bool global_ba_keeps_server_datum = true;
  // Local BA in a registered segment also frees the lines of its X' (with their virtual
  // observations e_vL by every server keyframe that sees them), so that the client corrects the
  // line cloud where the server's own views cannot see an error: along their viewing rays, the
  // depth a monocular server map gets least right. The paper's local BA (eq. 8) keeps lines
  // fixed, so the client inherits the server map's distortion. Measured at 100 frames, seeds 1-2
  // (docs/benchmarks-lcvslam.md): APE lower in all 7 cases (e.g. fisheye s2 0.62 -> 0.11 m).
  bool local_ba_frees_line_cloud = true;
  // ... and the server keyframes that see the most of those lines, up to this many (the others
  // that see them are the fixed border). 0 (default): every server keyframe fixed. Freeing them
  // lets the client's own (monocular) scale bend the server map: measured worse on fisheye s1
  // (APE 0.59 / 0.66 / 0.73 / 0.88 m with 0 / 2 / 5 / 10 free).
  int local_ba_free_server_keyframes = 0;
  // Omega_vL of the virtual observations in global BA: false the paper's constant, true (default)
  // propagated from Omega_L (GlobalBAOptions::derived_virtual_information). Kept because it won
  // with the server datum (docs/paper-tables.md "Server datum", bench/paper_tables --quick
  // --tables 3, seeds 1-2): PGO + global BA 0.160 vs 0.200 m perspective, 0.308 vs 0.331 m
  // fisheye (3 of 4 runs lower; fisheye seed 1 higher), server keyframes' mean error
  // 0.267 -> 0.186 m vs -> 0.231 m. Local BA uses the constant.
  bool derived_virtual_information = true;
  // Virtual observations v (local and global BA) from each line and server keyframe as loaded,
  // the paper's L0 (LineCloudBundleOptions::virtual_from_published), instead of from the state
  // each bundle starts from, which lets lines moved by earlier local BAs stay where they went.
  // Measured (docs/slam.md "Local BA moves the client's lines"): after a loop, PGO + global BA
  // 24% / 15% lower for perspective / fisheye, 6% higher for equirectangular (Table 3, seeds
  // 1-4); on the 54 overlap runs 0.285 against 0.275 m. Mixed: off.
  bool virtual_from_published = false;
  // After each local BA, X' seen by >= 2 keyframes that lie more than this angle (degrees, seen
  // from the new keyframe) off their line's reference position become ordinary points and their
  // lines go back (slam/module/restored_point_release.h: wrong 2D-3D line associations). 0: off.
  // Measured (docs/slam.md "Wrong line associations"): 1.5 degrees lowers the APE in line clouds
  // without error (the paper's prebuilt maps, 6 pairs x 3 runs: 0.216 -> 0.167 m) and does not
  // in the Sim(3)-aligned SLAM maps of the protocol (54 runs: 0.275 -> 0.289 m) or
  // KITTI (0.279 -> 0.282 m): off.
  double release_off_line_deg = 0.0;
  // > 0: the virtual observations of local BA have a sigma of this many pixels of their server
  // keyframe's camera (PixelAngle: 1 / fx, 2 pi / cols for equirectangular) instead of the
  // constant 2e-3 rad, which is 0.77 px of the synthetic perspective camera, 0.37 px of the
  // fisheye, 0.2 px of the equirectangular and 1.4 px of KITTI's. 0 (default): the constant.
  // Measured with virtual_from_published (docs/benchmarks-lcvslam.md "Scene seeds 41-43"):
  // 1 px is better for perspective, about even for fisheye and worse for equirectangular.
  double virtual_sigma_px = 0.0;
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
  // The input is a live camera (lcv slam --realtime): a keyframe candidate that finds the
  // keyframe queue full is refused (SystemStats::keyframes_refused; tracking proposes the next
  // frame instead) rather than making tracking wait for mapping. Offline input (false) waits:
  // the dataset can be paused, a camera cannot. Ignored in deterministic mode.
  bool live = false;
  // Threaded mode: how much lower the background threads' priority is than the tracking
  // thread's, as a nice increment (0: the same; 1..19: lower, slam/util/thread_priority.h). The
  // map's writer (local mapping), loop closing and global BA only have to keep up on average;
  // tracking must answer each frame within its period. On a machine with fewer free cores than
  // busy threads, at the same priority the scheduler shares a core evenly and a frame waits for
  // a background thread's time slice (docs/benchmarks-slam.md "Threads": every tracking frame
  // above twice the median had been preempted, its CPU time was ordinary). At 5 the tracking
  // thread's CFS weight is ~3x theirs (1024 vs 335); they still get every core tracking leaves
  // idle. 10 (~9x) cut latency about as much but refused more keyframes on KITTI 00 under load
  // (mapping got less CPU against other programs): measured in docs/benchmarks-slam.md.
  // Ignored in deterministic mode (one thread).
  int background_nice = 5;
  std::uint64_t seed = 1;

  // Loop closing runs: enabled, a non-empty vocabulary, and not localization-only.
  bool LoopClosingActive() const;
};

}  // namespace lcv::slam
