#pragma once
// Guided matching of 3D landmarks into a frame by projection (ORB-SLAM's SearchByProjection),
// used by tracking against the last frame and against the local map.
//
// Each candidate is projected with the frame's camera at a given pose; the frame's keypoints
// within radius_px of the projection and in the candidate's octave band are compared by Hamming
// distance. A match needs distance <= max_hamming_distance and, when a second candidate keypoint
// exists at the same octave, best < ratio * second. An optional orientation-consistency histogram
// (the rotation between the candidate's reference keypoint and the matched keypoint) keeps only
// the three dominant bins. A keypoint already holding a landmark is skipped; when two candidates
// pick the same free keypoint the closer descriptor wins.

#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "slam/data/frame.h"
#include "slam/feature/keypoint.h"
#include "slam/geometry/rigid3.h"
#include "slam/match/free_keypoint_cells.h"
#include "slam/util/ids.h"
#include "slam/util/parallel_for.h"

namespace lcv::slam {

struct ProjectionCandidate {
  Id landmark_id = kInvalidId;
  Eigen::Vector3d position_in_world = Eigen::Vector3d::Zero();
  OrbDescriptor descriptor{};
  int min_octave = 0;  // octave band searched, inclusive; max_octave < 0: no upper bound
  int max_octave = -1;
  float radius_px = 10.f;  // search window half-size at the predicted octave
  // Orientation of the keypoint the candidate was last matched to (degrees); < 0 excludes the
  // candidate from the orientation check.
  float reference_angle_deg = -1.f;
};

struct ProjectionMatchOptions {
  int max_hamming_distance = 100;  // ORB-SLAM's TH_HIGH
  float ratio = 0.9f;              // best < ratio * second best (same octave); 1 disables
  bool check_orientation = true;
  int orientation_bins = 30;
  double image_margin_px = 0.0;  // projections closer to the border are skipped
  // Cell size (px) of the search grid of free keypoints built once per call
  // (slam/match/free_keypoint_cells.h). Among equal distances the keypoint first in the frame
  // grid's order wins, so the matches are those of the frame grid, bit for bit. 0 searches the
  // frame's grid.
  int search_cell_px = 8;
  // Threads of the per-candidate search (the caller and num_threads - 1 helpers of the
  // scratch's pool). Each candidate's best keypoint is found independently and the candidates
  // are then combined in their order, so the matches do not depend on it. 1: the caller only.
  int num_threads = 1;
};

// What the search found for one candidate (ProjectionMatchScratch::per_candidate).
struct ProjectionCandidateBest {
  int distance = 0;
  int keypoint = -1;  // -1: no keypoint passed
};

// Reusable per-call buffers (STYLE.md 8): keep one per tracking thread.
struct ProjectionMatchScratch {
  std::vector<int> window;  // frame grid query result (search_cell_px 0)
  std::vector<int> best_distance_per_keypoint;
  std::vector<int> candidate_per_keypoint;
  std::vector<std::vector<int>> rotation_bins;
  std::vector<ProjectionCandidateBest> per_candidate;
  // Search grid of the free keypoints (search_cell_px > 0) and each slot's rank in the frame
  // grid's order (ties go to the lower rank).
  FreeKeypointCells free_cells;
  std::vector<std::int64_t> cell_rank;
  std::unique_ptr<ParallelFor> pool;  // num_threads > 1; started on first use
};

// Matches candidates into frame->landmark_ids (clearing the outlier flag of new matches) with
// the frame seen from cam_from_world. Returns the number of new matches. Requires a prepared
// frame (PrepareFrame).
int MatchByProjection(const std::vector<ProjectionCandidate>& candidates,
                      const Rigid3d& cam_from_world, const ProjectionMatchOptions& options,
                      Frame* frame, ProjectionMatchScratch* scratch);

// Keeps the indices of the three most populated bins of an orientation histogram (ORB-SLAM's
// ComputeThreeMaxima): bins with less than 10% of the largest bin's count are dropped too.
// Returns a mask over bins (1 = keep).
std::vector<unsigned char> DominantRotationBins(const std::vector<std::vector<int>>& bins);

// Histogram bin of the rotation from angle_a to angle_b (degrees).
int RotationBin(float angle_a_deg, float angle_b_deg, int num_bins);

}  // namespace lcv::slam
