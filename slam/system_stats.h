#pragma once
// What the engine did (System::Stats, slam/system.h), for lcv slam's --stats-out.

#include <string>
#include <vector>

#include "slam/util/ids.h"
#include "slam/util/lock_timing.h"

namespace lcv::slam {

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
  int local_ba_stopped_early = 0;  // live: ended when tracking queued the next keyframe
  int keyframes_reanchored = 0;    // live: the map moved between tracking and mapping them
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
  // Times the registered client left the line cloud (SlamMap::LineCloudDetached).
  int line_cloud_detachments = 0;
  bool relocalized_in_line_cloud = false;
  // The active map (the one the trajectories and --map-out hold) is registered in the line
  // cloud's frame. False although relocalized_in_line_cloud when the registered map was lost
  // and the new one has not registered again (docs/slam.md "Interruptions in a line cloud").
  bool trajectory_in_line_cloud_frame = false;
  // A point map with keyframes was loaded and the active map (trajectories) is in its frame:
  // false while a camera that started outside it maps on its own and has not merged into it
  // (docs/slam.md "A camera that starts outside a loaded map"; --map-out then holds the loaded
  // map).
  bool loaded_map = false;
  bool trajectory_in_loaded_map_frame = false;
  double line_cloud_registration_timestamp = 0.0;
  std::string line_cloud_method;  // "p4l", "p3p" or "p6l-views" of the registration
  int line_cloud_inliers = 0;
  double line_cloud_scale = 0.0;  // server_from_client scale
  double line_cloud_registration_ms = 0.0;
  int restored_points = 0;        // X' in the exported map's segment
  int restored_points_released = 0;  // X' made ordinary points (LineCloud.release_off_line_deg)
  std::string line_cloud_problem;
  std::string line_cloud_last_failure;  // of the last failed registration attempt
  // Every registration attempt (the first kMaxLineCloudAttemptLog), for the user to see why a
  // client registered late or not at all: which keyframe, how many server keyframes and lines
  // were matched, the matches and inliers, and what stopped it.
  struct LineCloudAttempt {
    Id keyframe_id = kInvalidId;
    double timestamp = 0.0;
    int candidates = 0;           // server keyframes whose lines were matched
    int lines = 0;                // their lines
    int point_line_matches = 0;   // N_PL
    int point_point_matches = 0;  // N_PP
    int inliers = 0;
    std::string method;           // "p4l", "p3p" or empty
    bool success = false;
    std::string failure;
    double time_ms = 0.0;
    // Where P4L / P3P failed, the registration from keyframe views tried next
    // (slam/module/line_cloud_view_registration.h): the views it had (-1: not tried) and why it
    // did not register (empty when it did: then success, method "p6l-views" and inliers are its).
    int views = -1;
    std::string views_failure;
    double views_ms = 0.0;
  };
  static constexpr int kMaxLineCloudAttemptLog = 100;
  std::vector<LineCloudAttempt> line_cloud_attempt_log;
  // Live mode (SystemOptions::live): keyframe candidates refused because the keyframe queue
  // was full (mapping behind); tracking proposed a later frame instead.
  int keyframes_refused = 0;
  // Threaded mode: lost frames not handed to relocalization because the previous request was
  // still being served (at most one is outstanding).
  int relocalizations_skipped = 0;
  // Frames the line-cloud check ran on, and the poses it refused
  // (TrackingSettings::line_cloud_check_*).
  int line_cloud_checks = 0;
  int line_cloud_check_refusals = 0;
  int line_cloud_check_adoptions = 0;  // frames re-tracked from p6L's pose (more inliers)
  int line_cloud_checks_cut_short = 0;  // live: checks that their time budget ended
  // Lost frames relocalized by p6L in the line cloud (RelocalizationSettings::in_line_cloud),
  // and the p6L attempts for them (those that failed included). Counted in relocalizations too.
  int line_cloud_relocalizations = 0;
  int line_cloud_relocalization_attempts = 0;
  // How long each thread held a lock on state it shares with the others (snapshot slot, work
  // queues, hand-over slots; the map itself has no lock: its one writer owns it). Filled after
  // Finish(); the tracking entry also before.
  LockHoldSummary map_lock_tracking;
  LockHoldSummary map_lock_mapping;
  LockHoldSummary map_lock_loop_closing;
  // Threaded mode: copies of the map and keyframe database handed to loop closing (one per
  // keyframe while the stage is idle), and their cost on the mapping thread.
  int loop_input_copies = 0;
  double loop_input_copy_ms = 0.0;      // total
  double loop_input_copy_max_ms = 0.0;  // longest
  // Threaded mode: keyframes handed to loop detection, and how many of them were still waiting
  // when the run finished (the stage was busy, e.g. solving a global BA that outlasted the rest
  // of an offline sequence) and were handed over by Finish() (System::Impl::FlushLoopClosing).
  // loop_input_keyframes_unexamined: keyframes never handed over (0 unless the stage did not
  // come to rest within the bounded flush).
  int loop_input_keyframes = 0;
  int loop_input_keyframes_at_finish = 0;
  int loop_input_keyframes_unexamined = 0;
  // Threaded mode: the nice values the threads run at (slam/util/thread_priority.h), as read by
  // each thread after SystemOptions::background_nice was applied; the error when the system
  // refused it (empty: applied). Filled after Finish(); tracking's (the caller's) also before.
  int tracking_thread_nice = 0;
  int mapping_thread_nice = 0;
  int loop_closing_thread_nice = 0;
  std::string thread_priority_error;
  int maps_kept = 0;    // lost maps kept as inactive segments (LoopClosingSettings::merge_maps)
  // Kept segments with frames of the run's own that the outputs leave out (never merged, not
  // the output segment: SlamMap::OutputSegment).
  int maps_left_out = 0;
  int maps_merged = 0;  // of those, merged back by a loop
  std::vector<LoopEvent> loops;
  // Every global BA solved (applied or found stale), for the user to see whether it converged:
  // the problem's size, Ceres' iterations and costs over both passes (robust, then without
  // outliers), the observations flagged outlier, and the termination message.
  struct GlobalBARun {
    double timestamp = 0.0;  // of the newest keyframe of the job
    bool applied = false;    // false: a later loop correction made the job stale
    bool line_cloud = false;
    int keyframes = 0;
    int server_keyframes = 0;
    int points = 0;
    int lines = 0;
    int observations = 0;
    int virtual_observations = 0;
    int iterations = 0;
    double initial_cost = 0.0;
    double final_cost = 0.0;
    int outliers = 0;
    double solve_ms = 0.0;
    std::string message;
  };
  std::vector<GlobalBARun> global_ba;
};

}  // namespace lcv::slam
