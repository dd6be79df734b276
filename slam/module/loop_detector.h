#pragma once
// Loop detection (ORB-SLAM2's LoopClosing::DetectLoop and ComputeSim3, Mur-Artal and Tardos,
// T-RO 2017, Sec. VI), as a thread-agnostic stage: the caller (System's loop-closing thread)
// passes the map and the keyframe database and guarantees that nobody writes them during the
// call.
//
// Per new keyframe (the query):
// 1. candidates (KeyFrameDatabase::DetectLoopCandidates): keyframes returned by the BoW database
//    that are not covisible with the query, share at least 80% of the largest number of shared
//    words and score at least the lowest BoW score between the query and its covisible
//    neighbours; each is grouped with its 10 best covisibles, and the groups whose accumulated
//    score reaches 75% of the best group's give their best keyframe;
// 2. consistency: a candidate's group (it and its covisibles) must intersect a group kept from
//    the previous query; a chain of consistency_threshold (3) such links over consecutive
//    queries makes it a loop candidate;
// 3. Sim(3) (monocular: the scale is estimated): BoW matches between the query's and the
//    candidate's landmark-bearing keypoints (direct index, rotation-consistency check) give
//    3D-3D correspondences (each keyframe's landmarks in its own camera frame); RANSAC over
//    slam/optimize/sim3_reprojection.h (inlier: reprojection chi^2 <= 9.21 at the keypoint's
//    octave in BOTH images, ORB-SLAM's Sim3Solver test, which scales the 3D tolerance with depth
//    and octave as it should);
//    guided matching (each side's landmarks projected into the other with the Sim(3), mutual
//    best matches kept); Gauss-Newton refinement on the reprojection errors with outlier
//    removal; >= 20 inliers;
// 4. the landmarks of the candidate and its covisibles are projected into the query at the
//    corrected pose; the loop is accepted with >= 40 matched query keypoints in total.
//
// Frames: corrected_query_cam_from_world maps the MATCH side's world (the consistent one) into
// the query camera, with the query's scale (x_cam = s R X + t); CorrectLoop
// (slam/module/loop_closer.h) turns it into a rigid pose.
//
// Thread safety: not thread-safe; one instance per loop-closing thread. Reads map and database
// only. Deterministic for a given seed.

#include <cstdint>
#include <optional>
#include <set>
#include <utility>
#include <vector>

#include "slam/bow/bow_database.h"
#include "slam/bow/direct_index_matcher.h"
#include "slam/data/slam_map.h"
#include "slam/geometry/sim3.h"
#include "slam/util/ids.h"

namespace lcv::slam {

struct LoopDetectorOptions {
  // Queries skipped after construction, Reset() and each detected loop (ORB-SLAM: 10 keyframes).
  int min_keyframes_between_loops = 10;
  int consistency_threshold = 3;        // consecutive consistent queries
  int group_size = 10;                  // best covisibles grouped with a candidate
  double min_shared_words_ratio = 0.8;  // of the largest number of shared words
  double min_group_score_ratio = 0.75;  // of the best accumulated score
  DirectIndexMatchOptions bow_matching;  // TH_LOW, ratio 0.75
  bool check_orientation = true;         // BoW matches: 3 dominant keypoint-rotation bins
  int min_bow_matches = 20;
  double ransac_chi2 = 9.21;  // per side, at the keypoint's octave (2 dof, 99%)
  int ransac_max_trials = 300;
  double ransac_confidence = 0.99;
  int min_sim3_inliers = 20;
  float guided_radius_factor = 7.5f;      // SearchBySim3 window, x octave scale (px)
  int guided_max_hamming_distance = 100;  // TH_HIGH
  double refine_chi2 = 10.0;              // OptimizeSim3
  float projection_radius_factor = 10.f;  // final SearchByProjection window
  int min_total_matches = 40;
};

struct LoopDetection {
  Id query_keyframe_id = kInvalidId;
  Id match_keyframe_id = kInvalidId;
  // The query's pose made consistent with the match side (see the header comment).
  Sim3d corrected_query_cam_from_world;
  // Query keypoint index -> landmark of the match side (the refined Sim(3) inliers and the
  // landmarks of the match keyframe's covisible group projected into the query), by index.
  std::vector<std::pair<int, Id>> matches;
  int num_inliers = 0;  // Sim(3) inliers after refinement (before the final projection)
};

// What the last Detect call got to (for statistics and diagnosis of missed loops): counts are 0
// for the stages it did not reach; the Sim(3) stages report the candidate that got furthest.
struct LoopDetectionAttempt {
  Id query_keyframe_id = kInvalidId;
  bool skipped = false;        // within min_keyframes_between_loops, or no BoW vector
  int num_candidates = 0;      // after the score and group tests
  int num_consistent = 0;      // consistent over consistency_threshold queries
  Id best_candidate_id = kInvalidId;
  int num_bow_matches = 0;
  int num_ransac_inliers = 0;
  int num_refined_inliers = 0;
  int num_total_matches = 0;   // after the projection of the match side's group
  bool detected = false;
};

class LoopDetector {
 public:
  explicit LoopDetector(const LoopDetectorOptions& options = LoopDetectorOptions());

  // Call once per new keyframe, in insertion order, after local mapping processed it (and after
  // it was added to the database, or not: it is excluded from its own query). Keeps the
  // consistency groups between calls.
  std::optional<LoopDetection> Detect(const SlamMap& map, const BowDatabase& database,
                                      Id keyframe_id, std::uint64_t seed);

  // Forgets the consistency groups and restarts the skip count (a new map).
  void Reset();

  const LoopDetectionAttempt& last_attempt() const { return last_attempt_; }

  const LoopDetectorOptions& options() const { return options_; }

 private:
  struct ConsistentGroup {
    std::set<Id> keyframes;
    int consistency = 0;
  };

  std::vector<Id> DetectCandidates(const SlamMap& map, const BowDatabase& database,
                                   const SlamKeyframe& query) const;
  // Updates consistent_groups_ and returns the candidates consistent long enough.
  std::vector<Id> CheckConsistency(const SlamMap& map, const std::vector<Id>& candidates);
  std::optional<LoopDetection> ComputeSim3(const SlamMap& map, const SlamKeyframe& query,
                                           const SlamKeyframe& candidate, std::uint64_t seed,
                                           LoopDetectionAttempt* attempt) const;

  LoopDetectorOptions options_;
  std::vector<ConsistentGroup> consistent_groups_;
  int queries_since_reset_ = 0;
  LoopDetectionAttempt last_attempt_;
};

}  // namespace lcv::slam
