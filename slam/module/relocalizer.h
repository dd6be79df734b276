#pragma once
// Relocalization of a frame in a map by place recognition (ORB-SLAM2's
// Tracking::Relocalization with KeyFrameDatabase::DetectRelocalizationCandidates), used when
// tracking is lost and to start tracking in a loaded map.
//
// 1. Candidates (RelocalizationCandidates): keyframes of the map's active segment in the BoW
//    database (inactive segments are other maps' frames, see SlamMap) sharing words with the
//    frame, those with >= min_common_words_ratio of the best word count kept and scored (L1);
//    each kept keyframe's score is accumulated with its group_neighbours best covisible
//    keyframes that were kept too; groups scoring > group_score_ratio * the best group give
//    their best-scoring keyframe. Best group first, at most max_candidates; then the
//    raw_score_candidates best keyframes by their own score not listed yet (the frontier
//    keyframe a frame leaving the map sees best has few neighbours to form a strong group).
// 2. Per candidate, in that order: its landmarks matched into the frame through the direct index
//    (slam/match/bow_matcher.h: ratio test, orientation histogram); >= min_bow_matches needed.
// 3. P3P RANSAC on the frame's unit bearings against the landmarks (slam/solve/absolute_pose.h),
//    so every camera model works the same; threshold in radians, from pixels through the
//    camera's angular resolution unless given.
// 4. Motion-only BA (slam/optimize/motion_only_ba.h, rounds with outlier rejection) from the
//    RANSAC pose, on all BoW matches with the RANSAC outliers starting excluded (BA re-admits
//    those that fit the refined pose); fewer than min_optimized_inliers inliers: next candidate.
// 5. Below min_inliers: the landmarks of the candidate and its local_keyframes best covisible
//    keyframes are searched by projection at the new pose (window wide_search_radius_px times
//    the predicted octave's scale, Hamming <= wide_search_max_distance) and BA runs again if
//    that can reach min_inliers; with more than narrow_search_min_inliers but still too few, a
//    narrow search (narrow_search_radius_px, narrow_search_max_distance) and BA once more.
// 6. Success at >= min_inliers inliers.
//
// Units: angles in radians, windows in pixels (times the octave scale), distances in Hamming
// bits. Thread safety: reads the vocabulary, database and map only; the caller keeps the map and
// database from changing during the call (e.g. runs it where the map is owned, or under its lock).

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "slam/bow/bow_database.h"
#include "slam/bow/vocabulary.h"
#include "slam/data/frame.h"
#include "slam/data/slam_map.h"
#include "slam/util/ids.h"

namespace lcv::slam {

struct RelocalizerOptions {
  // Candidates (step 1).
  int max_candidates = 10;              // group bests
  double min_common_words_ratio = 0.8;  // of the most words shared by any keyframe
  int group_neighbours = 10;            // covisible keyframes scored with a candidate
  double group_score_ratio = 0.75;      // of the best accumulated group score
  int raw_score_candidates = 3;         // best keyframes by their own score, tried too

  // BoW matching (step 2).
  int min_bow_matches = 15;
  int bow_max_distance = 50;  // Hamming bits (ORB-SLAM's TH_LOW)
  float bow_ratio = 0.75f;    // nearest / second nearest
  bool check_orientation = true;

  // P3P RANSAC (step 3): inlier threshold on the angle between a keypoint's bearing and the
  // direction to its landmark. When max_angular_error_rad is 0 (the default) it is
  // max_ransac_error_px times the angle one pixel spans at the image centre, so that one
  // setting fits every camera (3 px: 0.006 rad at a 500 px focal length, 0.029 rad on a 640 px
  // wide equirectangular image); a positive value is used as is.
  double max_angular_error_rad = 0.0;
  double max_ransac_error_px = 3.0;
  int max_ransac_trials = 300;
  int min_ransac_inliers = 10;

  // Pose optimization and projection search (steps 4-6).
  int min_optimized_inliers = 10;
  int min_inliers = 50;
  int local_keyframes = 10;
  float wide_search_radius_px = 10.f;
  int wide_search_max_distance = 100;  // ORB-SLAM's TH_HIGH
  int narrow_search_min_inliers = 30;
  float narrow_search_radius_px = 3.f;
  int narrow_search_max_distance = 64;

  // Empty when usable, else what is wrong ("min_inliers must be >= 3").
  std::optional<std::string> Problem() const;
};

struct RelocalizationResult {
  Id keyframe_id = kInvalidId;   // the candidate the frame was relocalized against
  int num_inliers = 0;           // landmark matches after the final pose optimization
  int num_candidates_tried = 0;  // candidates examined, the successful one included
};

// Candidate keyframes for a frame's BoW vector (step 1), best first. Keyframes of the database
// missing from the map are ignored.
std::vector<Id> RelocalizationCandidates(const BowDatabase& database, const SlamMap& map,
                                         const BowVector& bow, const RelocalizerOptions& options);

// frame: prepared (PrepareFrame) with descriptors and camera. Computes frame->bow and
// frame->direct_index (at kDirectIndexLevel) when either is empty. On success sets
// frame->cam_from_world, has_pose = true, reference_keyframe_id = the keyframe, and
// landmark_ids / is_outlier to the inlier matches only (landmarks of `map`, no outlier flags
// set). On failure clears the frame's matches, leaves its pose fields as they were and returns
// nullopt. Deterministic for a given seed. Precondition: !options.Problem() (checked).
std::optional<RelocalizationResult> Relocalize(const Vocabulary& vocabulary,
                                               const BowDatabase& database, const SlamMap& map,
                                               const RelocalizerOptions& options,
                                               std::uint64_t seed, Frame* frame);

}  // namespace lcv::slam
