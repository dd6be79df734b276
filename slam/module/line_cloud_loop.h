#pragma once
// Loop closing against the server's line cloud (paper Sec. 3.2 and 3.4). A client registered
// in the line cloud that leaves it maps on its own and drifts; when it comes back, its new
// keyframe registers into the line cloud again, and the difference between where the client's
// map puts the keyframe and where the line cloud does is the drift that the loop corrects.
// The line cloud is the loop's match side: it is the fixed reference, as the match keyframe is
// in an ordinary loop (slam/module/loop_closer.h).
//
// Detection (DetectLineCloudLoop), per new keyframe of the registered active segment:
// 1. candidate server keyframes by BoW from their lines' descriptors (the relocalizer's
//    database), the keyframe's points X_ckf matched to their lines and to the X' restored on
//    them earlier (points already in the server frame), and registered by P4L or P3P Sim(3)
//    RANSAC (the paper's rule) and the rigid-stereo BA of eq. 7 (MatchKeyframeToLineCloud);
// 2. accepted with at least min_inliers verified correspondences, when the registration moves
//    the query by more than the drift thresholds (inside the line cloud, tracking's line matches
//    and local BA hold the map to the lines, and a registration finds no drift: no loop), or
//    whatever it moves the query by when the map is detached from the line cloud.
//
// Leaving and re-entering (UpdateLineCloudDetachment, called by the map's writer after each
// keyframe): a client whose new keyframes observe almost no X' has left the line cloud, and the
// map is marked detached (SlamMap::LineCloudDetached). Its snapshots then carry no server
// keyframe's lines, so when the client comes back tracking does not find the lines near its
// drifted prediction and pull the newest frames onto them while the keyframes of the loop keep
// their drift (measured on the 300-frame perspective loop pair, seed 1: tracking matched lines
// again 4 s before the first registration, which then found 4 cm left to correct and closed no
// loop). The return is left to detection here, which skips the drift gate while detached (the
// drift is then the loop's, not what tracking left of it); the correction attaches the map
// again. A keyframe that observes enough X' again (window X' matched by projection, e.g. after
// the camera looked away briefly) attaches it too.
// Reads the map only. Cost: one BoW query and one registration per call (the caller limits
// how often; System checks every keyframe after min_keyframes_between_loops since the last).
//
// Correction (CorrectLineCloudLoop), with exclusive access to the map (the caller is its writer):
// 1. the keyframe's covisible neighbourhood takes the registered pose (CorrectNeighbourhood);
// 2. fusion: an inlier point matched to an X' is replaced by it (the loop's link to the part of
//    the map registered before); an inlier point matched to a line without X' becomes its X' at
//    the rigid-stereo BA position;
// 3. the Sim(3) essential graph over the segment with keyframes fixed: the query (placed by
//    the line cloud), the anchor, the keyframe outside the neighbourhood that observes at
//    least min_anchor_restored X' and became most covisible with the neighbourhood in step 2
//    (else the one with the most X'), and the keyframes made while the map was attached to the
//    line cloud that observe as many X' (hold_keyframes_made_in_line_cloud); the drift is spread
//    over the keyframes made while detached. Fixing every keyframe with X' was measured worse
//    for the pose graph alone (fisheye loop, seed 3: APE 1.57 -> 1.57 m vs 1.06 m), as
//    keyframes restore X' while drifting too: those are made while detached, and stay free;
// 4. a loop edge between the query and the anchor, so that later pose graphs keep the link and
//    global BA jobs captured before are recognised as stale;
// 5. X' that the corrected map puts far from their lines (more than release_chi2 under
//    Omega_L) are released, made ordinary points: they were restored from drifted poses (a
//    client sees the line cloud's structure from outside it) and global BA would pull the map
//    back onto them.
// Global BA over lines, server keyframes and the client map (eq. 9) follows in the caller
// (slam/module/global_bundle_adjustment.h).

#include <cstdint>
#include <optional>

#include "slam/bow/bow_database.h"
#include "slam/bow/vocabulary.h"
#include "slam/data/slam_map.h"
#include "slam/geometry/sim3.h"
#include "slam/module/line_cloud_relocalizer.h"
#include "slam/module/loop_closer.h"

namespace lcv::slam {

struct LineCloudLoopOptions {
  // A registration that moves the query less than all of these is no loop (no drift to
  // correct): min_drift_of_depth times the median depth of its points, min_drift_deg, and a
  // scale change of exp(min_drift_scale).
  double min_drift_of_depth = 0.02;
  double min_drift_deg = 1.0;
  double min_drift_scale = 0.02;
  // Keyframes skipped after a correction (ORB-SLAM waits 10 keyframes between loops).
  int min_keyframes_between_loops = 5;
  int min_inliers = 30;  // verified point-line and point-point correspondences
  // Keyframes observing at least this many X' are held by the line cloud (fixed in step 3).
  int min_anchor_restored = 10;
  // Step 3 also holds fixed every keyframe of the segment outside the query's neighbourhood that
  // was made while the map was attached to the line cloud (SlamKeyframe::made_in_line_cloud)
  // and observes at least min_anchor_restored X': the stretch registered before the client left
  // is where the line cloud put it, and the drift belongs to the keyframes made while detached.
  // Off, only the query and the anchor are fixed, and the pose graph bent the registered stretch
  // too. Measured on 15 Table-3 loop runs (docs/paper-tables.md "Holding the keyframes made in
  // the line cloud"): on, PGO alone is 2.3x better (worse than no correction in 3 runs instead
  // of 13); after global BA 0.97x-1.03x, perspective 20-40% worse on three of five seeds.
  bool hold_keyframes_made_in_line_cloud = true;
  // Detached after detach_after_keyframes consecutive new keyframes that each observe fewer
  // than detach_below_restored X' or have no server keyframe within detach_beyond_depths times
  // the median depth of their points (0: that part off). detach_below_restored 0: never
  // detached, tracking re-enters by itself. Only applies where line-cloud loops are closed
  // (loop closing is what attaches again). The distance test is what detaches an
  // equirectangular client: it keeps 8-31 X' in view from the street beside the mapped one
  // (loop pair seed 2 of paper_tables --quick; docs/slam.md).
  int detach_below_restored = 10;
  double detach_beyond_depths = 1.0;
  int detach_after_keyframes = 2;
  // Step 5: X' farther from their line than this after the correction (chi^2 under Omega_L,
  // 2 dof; 100 = 10 sigma) are released (become points). Measured (PGO + global BA, loop
  // seed 3, APE m, equirectangular / fisheye): never 4.40 / 1.03; 10000: 2.01 / 1.00;
  // 1000: 0.62 / 0.58; 100: 0.88 / 0.62; 36.8: 0.75 / 0.71.
  double release_chi2 = 100.0;
  LineCloudRelocalizerOptions relocalizer;
  LoopCloserOptions loop_closer;
};

// Whether the map is detached from the line cloud once keyframe_id (its newest keyframe, of the
// registered active segment) is in it: *low_streak counts consecutive keyframes with fewer than
// options.detach_below_restored X' (the caller keeps it, starting at 0); detached when it reaches
// detach_after_keyframes. A streak left from before a correction that attached the map again
// starts over. The caller stores the result (SlamMap::SetLineCloudDetached). False for an
// unregistered segment or detach_below_restored <= 0.
bool UpdateLineCloudDetachment(const SlamMap& map, Id keyframe_id,
                               const LineCloudLoopOptions& options, int* low_streak);

struct LineCloudLoopDetection {
  Id query_keyframe_id = kInvalidId;
  // The server world into the query camera, with the query's scale (x_cam = s R X + t), as
  // LoopDetection::corrected_query_cam_from_world with the line cloud as the match side.
  Sim3d corrected_query_cam_from_world;
  LineCloudRegistration registration;  // server_from_client, inliers (restored, point_matches)
  int num_candidates = 0;
};

std::optional<LineCloudLoopDetection> DetectLineCloudLoop(const Vocabulary* vocabulary,
                                                          const BowDatabase& server_database,
                                                          Id query_keyframe_id,
                                                          const LineCloudLoopOptions& options,
                                                          std::uint64_t seed, const SlamMap& map);

struct LineCloudLoopCorrection {
  LoopCorrectionReport report;  // success, num_fused, keyframes corrected, pose graph
  Id anchor_keyframe_id = kInvalidId;  // the loop edge's other end
  int num_restored = 0;                // new X' (step 2)
  int num_released = 0;                // X' made points again (step 5)
  int num_fixed_keyframes = 0;         // keyframes held in step 3 (the query, the anchor and
                                       // those made in the line cloud)
};

// Failure (report.success false, map unchanged): the query is gone or not in the registered
// segment. Success attaches the map to the line cloud again (SlamMap::SetLineCloudDetached).
LineCloudLoopCorrection CorrectLineCloudLoop(const LineCloudLoopDetection& loop,
                                             const LineCloudLoopOptions& options, SlamMap* map);

}  // namespace lcv::slam
