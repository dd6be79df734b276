#pragma once
// What System::TrackImage returns per frame (slam/system.h), apart from the engine so that the
// tracking stage (slam/tracking.h) can produce it without including the engine.

#include <optional>

#include "slam/geometry/rigid3.h"
#include "slam/util/ids.h"

namespace lcv::slam {

enum class TrackingState { kInitializing, kTracking, kLost };
const char* TrackingStateName(TrackingState state);  // "initializing", "tracking", "lost"

// Where the tracking thread's wall time went in one frame (ms; 0 for a stage not run). Parts of
// FrameResult::tracking_ms (with extraction_ms), so that the frames making its p99 can be
// explained (issue 14, docs/benchmarks-slam.md "Threads").
struct TrackingStageTimes {
  double handover_ms = 0.0;      // taking the writer's answers and the latest snapshot (threads)
  double initializer_ms = 0.0;   // two-view initialization attempt (no map yet)
  double initialization_frames_ms = 0.0;  // posing the frames an initialization waited through
  double motion_ms = 0.0;        // constant velocity: last frame's points by projection, pose BA
  double recovery_ms = 0.0;      // when that failed: wide local-map search, P3P, pose BA
  double relocalization_ms = 0.0;  // BoW + PnP in the whole map (inline), or its request
  double two_view_ms = 0.0;      // when all that failed: the pose from 2D-2D matches to the last frame
  double local_map_ms = 0.0;     // local-map points (and lines) by projection, pose BA
  double keyframe_decision_ms = 0.0;  // keyframe decision, the frame's record, the candidate
};

struct FrameResult {
  Id frame_id = kInvalidId;
  double timestamp = 0.0;
  TrackingState state = TrackingState::kInitializing;
  std::optional<Rigid3d> cam_from_world;  // when tracked (or just initialized)
  int num_keypoints = 0;
  int num_matches = 0;  // inlier landmark matches after pose optimization
  // Of those, the e_pL terms: keypoints matched to an X' or to a line of the line cloud.
  int num_line_matches = 0;
  // Lines of the line cloud searched by projection in this frame (MatchLinesByProjection's
  // candidates: window lines without a matched X'), and those skipped by the line search's
  // back-off (slam/match/line_search_backoff.h).
  int num_lines_searched = 0;
  int num_lines_backed_off = 0;
  bool is_keyframe = false;  // handed to mapping as a keyframe (or initial keyframe)
  bool relocalized = false;  // pose found by relocalization (BoW + PnP) in this frame
  bool two_view = false;     // pose found by the two-view step (slam/tracking.h, step 3)
  double extraction_ms = 0.0;  // feature extraction part of tracking_ms
  double tracking_ms = 0.0;    // whole TrackImage call minus mapping_ms
  TrackingStageTimes stages;   // tracking_ms - extraction_ms, by stage
  // The tracking thread's own CPU time over tracking_ms's span (slam/util/thread_clock.h), and
  // how often it was preempted meanwhile: tracking_ms well above tracking_cpu_ms with
  // preemptions is time spent waiting for a core, not work.
  double tracking_cpu_ms = 0.0;
  long preemptions = 0;
  // Deterministic mode: inline mapping time; threaded mode: time spent waiting for room in the
  // keyframe queue (mapping falling behind). Both include a (re)initialization's map building.
  double mapping_ms = 0.0;
};

}  // namespace lcv::slam
