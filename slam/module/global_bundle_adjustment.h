#pragma once
// Global bundle adjustment of the running SLAM map in three steps, so that a background thread
// holds the map lock only briefly (ORB-SLAM2's LoopClosing::RunGlobalBundleAdjustment, with the
// map copied instead of locked during the solve; STYLE.md 5):
//
//   GlobalBAJob job = CaptureGlobalBA(map);   // under the lock: copies poses, points, links
//   SolveGlobalBA(options, &job);             // no map access: Ceres (slam/optimize/
//                                             //   bundle_adjustment.h), seconds on big maps
//   ApplyGlobalBA(job, &map);                 // under the lock: writes the result back
//
// The problem (slam/optimize/slam_map_bundle.h: points with e_pP, X' with e_pL and their lines
// fixed): every keyframe and every landmark with observations, every observation with the
// information of its keypoint's octave; the first keyframe is fixed (the gauge; monocular scale
// stays free, Levenberg-Marquardt keeps it near its start). Observations whose point the camera
// cannot image at capture time start as outliers. Outliers: BundleOptions' two-pass scheme.
//
// Apply handles what changed since Capture (local mapping kept running):
// - captured keyframes and landmarks that still exist take the optimized values;
// - keyframes added after Capture are corrected through the spanning tree from their nearest
//   captured ancestor: the pose relative to the parent (both at apply time, before writing) is
//   kept, child_from_world' = (child_from_world * parent_from_world^-1) * parent_from_world';
// - landmarks added after Capture move with their reference keyframe (or first observer):
//   X' = reference_from_world'^-1 * reference_from_world * X;
// - erased keyframes and landmarks are skipped;
// - observations flagged outliers by the solve are unlinked (SlamMap::RemoveObservation, so a
//   landmark left with fewer than 2 observations is erased) when the link still exists;
// - landmark geometry and covisibility are recomputed;
// - line-cloud jobs: lines take their optimized position and direction (anchored at the foot
//   of the old anchor, so a line's visible interval keeps its meaning) with Omega_L rotated by
//   the smallest rotation from the old direction to the new one; server keyframes their
//   optimized poses. Tracking sees them at the next snapshot.
// A job whose solve failed (or that was never solved) changes nothing, and so does a stale job:
// one captured before a loop correction that happened since (the map's loop-edge count
// changed; ORB-SLAM aborts the global BA then). Apply returns whether it wrote anything.
//
// Thread safety: Capture and Apply need the map not to be written meanwhile (the caller's lock);
// Solve touches only the job. A job holds no pointers into the map (the cameras it points to
// are owned by System and outlive it).

#include <cstddef>
#include <utility>
#include <vector>

#include "slam/data/slam_map.h"
#include "slam/optimize/bundle_adjustment.h"
#include "slam/optimize/slam_map_bundle.h"
#include "slam/util/ids.h"

namespace lcv::slam {

struct GlobalBAOptions {
  int max_iterations = 10;  // Ceres iterations per pass (ORB-SLAM: 10)
  bool refine_without_outliers = true;
  int num_threads = 1;
  // Line-cloud jobs: Omega_vL of each virtual observation propagated from the line's Omega_L
  // (VirtualObservationInformation, slam/optimize/residuals.h, floored at virtual_sigma_rad)
  // instead of the constant 1 / virtual_sigma_rad^2 of the paper.
  bool derived_virtual_information = false;
  double virtual_sigma_rad = 2e-3;
};

struct GlobalBAJob {
  BundleProblem problem;  // keyframes, points, observations (ids in BundleKeyframe/BundlePoint)
  // Per observation of the problem: the landmark, keyframe and keypoint it links.
  using Link = SlamMapBundleBuilder::Link;
  std::vector<Link> links;
  // Line-cloud jobs (CaptureGlobalBA with free_line_cloud): the SlamLine id of each
  // problem.lines entry (BundleLine::id is its X' landmark, kInvalidId for a line without one).
  bool line_cloud = false;
  std::vector<Id> line_ids;
  // Free server keyframes: after the solve, the whole job is moved by the similarity that puts
  // the server keyframe centres back where they were in the least-squares sense (see
  // CaptureGlobalBA); every server keyframe of the job is then written back.
  bool keep_server_datum = false;
  // keep_loaded_datum: the problem.keyframes indices of the loaded keyframes and their poses
  // at capture (empty otherwise).
  std::vector<int> loaded_keyframes;
  std::vector<Rigid3d> loaded_poses;
  std::size_t num_loop_edges = 0;  // of the map at capture, to detect stale jobs
  bool solved = false;
  BundleReport report;  // of SolveGlobalBA
};

// What CaptureGlobalBA puts in a job (the defaults are the conservative ones; the engine passes
// its settings). The fields are explained with CaptureGlobalBA below.
struct GlobalBACaptureOptions {
  bool free_line_cloud = false;
  bool free_server_keyframes = false;
  bool keep_server_datum = true;
  bool virtual_from_published = false;  // LineCloudBundleOptions::virtual_from_published
  bool keep_loaded_datum = false;
};

// Copies the map's active segment (SlamMap segments) into a job. Fast: linear in the number of
// observations.
//
// keep_loaded_datum (LoopClosing.keep_loaded_datum): keyframes read from a map file
// (SlamKeyframe::loaded) are free like the others, and after the solve the whole job is moved
// by the similarity that takes them back onto their captured poses (AlignMapDatum,
// slam/solve/umeyama.h: the centres' fit, or along a street, whose nearly collinear centres leave
// the rotation about it to noise, the rotations' mean): the map a client reuses may be reshaped
// by what the client saw but keeps its place, orientation and scale, as the loop's essential
// graph does
// (LoopCloserOptions::keep_loaded_datum) and as the server datum below does for a line cloud.
//
// free_line_cloud, on a map whose active segment is registered in a line cloud: the paper's
// global BA of eq. 9. The lines with an X' and every line seen by two or more server keyframes
// of the server keyframes that see one of them are free (minimal 4-dof updates,
// slam/optimize/bundle_adjustment.h), as are those server keyframes; each (server keyframe,
// line) pair of the job gives a virtual observation e_vL made from the state at capture. The
// gauge and the scale are fixed on the server map, not on the client's first keyframe: the
// server keyframes that see a line of the job but no X' line are added fixed; when there are
// fewer than two of those, the two free server keyframes seeing the fewest X' lines are fixed
// instead. Client keyframes are all free.
//
// free_server_keyframes false: every server keyframe of the job is fixed and only the lines
// move (held to their keyframes' view planes by e_vL and to the client by e_pL).
//
// free_server_keyframes true (the engine's default, LineCloud.global_ba_frees_server_keyframes,
// as the paper's eq. 9) with keep_server_datum (default, LineCloud.global_ba_keeps_server_datum):
// the server datum. The fixed keyframes above only make the solve well posed; after it, the
// whole job (client keyframes, points, X', lines, server keyframes) is moved by the similarity
// that takes the solved server keyframes back onto their captured poses (AlignMapDatum: the
// centres' least-squares fit, or, where the server keyframes lie along a street, the rotations'
// mean with the centres' scale and offset), and every server keyframe of the job is written
// back. This is a free-network adjustment with inner constraints (geodesy): the client may
// reshape the server map, but not move, turn or scale it as a whole. Why: a server map's frame
// belongs to the map as a whole (the benchmark's maps are placed by such a fit over all their
// keyframes), while the solve's gauge is just two keyframes, about which the server map (tied
// internally only by e_vL of shared lines, and outweighed by the client's observations of its
// X') turned and scaled toward the client's drifted trajectory. Measured (2026-11-24, commit
// 8ffb2af; the 300-frame loop pairs of bench/paper_tables --quick, seed 1 maps built at
// ac5c243, seed 2 maps of an earlier run; PGO + global BA; client APE without alignment,
// median / RMSE m; server keyframes' mean centre error to the ground truth, m, before -> after;
// docs/paper-tables.md "Server datum"):
//   perspective s1  fixed 0.431 / 0.617, 0.344 -> 0.344 (not moved)
//                   free, two fixed (no datum) 0.417 / 0.514, 0.344 -> 0.398 (away)
//                   free, server datum 0.273 / 0.580, 0.344 -> 0.222 (toward the truth)
//   fisheye s1      fixed 0.371 / 0.417; free no datum 0.378 / 0.426, 0.308 -> 0.309;
//                   server datum 0.341 / 0.400, 0.308 -> 0.268
//   fisheye s2      fixed 0.269 / 0.352; server datum 0.244 / 0.336, 0.289 -> 0.277
//   equirect. s2    fixed 0.275 / 0.375; server datum 0.260 / 0.359, 0.205 -> 0.199
//   perspective s2  fixed 0.181 / 0.381; free no datum 0.429 / 0.538, 0.128 -> 0.317;
//                   server datum 0.223 / 0.494, 0.128 -> 0.161 (the exception: a server map
//                   already good, reshaped for the worse by the client)
// Free without the datum the server map's shape did improve (perspective: Sim(3)-aligned
// centre RMSE to the truth 0.391 -> 0.251 m) while its placement went wrong (0.394 -> 0.438 m
// without alignment): the datum keeps the first and removes the second.
GlobalBAJob CaptureGlobalBA(const SlamMap& map, const GlobalBACaptureOptions& options = {});

// Optimizes the job's problem in place. A job without observations returns success with zero
// iterations.
BundleReport SolveGlobalBA(const GlobalBAOptions& options, GlobalBAJob* job);

// Writes a solved job into the map (see above). False (map unchanged) for a job that is not
// solved, failed, or stale.
bool ApplyGlobalBA(const GlobalBAJob& job, SlamMap* map);

}  // namespace lcv::slam
