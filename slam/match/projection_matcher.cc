#include "slam/match/projection_matcher.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>

namespace lcv::slam {

int RotationBin(float angle_a_deg, float angle_b_deg, int num_bins) {
  float rotation = angle_b_deg - angle_a_deg;
  if (rotation < 0.f) rotation += 360.f;
  int bin = static_cast<int>(std::lround(rotation * num_bins / 360.f));
  if (bin >= num_bins) bin -= num_bins;
  return std::clamp(bin, 0, num_bins - 1);
}

std::vector<unsigned char> DominantRotationBins(const std::vector<std::vector<int>>& bins) {
  const int n = static_cast<int>(bins.size());
  int best[3] = {-1, -1, -1};
  int count[3] = {0, 0, 0};
  for (int b = 0; b < n; ++b) {
    const int c = static_cast<int>(bins[b].size());
    if (c > count[0]) {
      best[2] = best[1], count[2] = count[1];
      best[1] = best[0], count[1] = count[0];
      best[0] = b, count[0] = c;
    } else if (c > count[1]) {
      best[2] = best[1], count[2] = count[1];
      best[1] = b, count[1] = c;
    } else if (c > count[2]) {
      best[2] = b, count[2] = c;
    }
  }
  std::vector<unsigned char> keep(n, 0);
  for (int k = 0; k < 3; ++k) {
    if (best[k] < 0) continue;
    if (k > 0 && count[k] < 0.1 * count[0]) continue;
    keep[best[k]] = 1;
  }
  return keep;
}

namespace {

// The best and second-best keypoint of one candidate as the frame grid's query order would
// leave them: among equal distances the keypoint that comes first in that order (rank) wins, so
// the result does not depend on the order the keypoints are offered in.
struct BestTwo {
  int best = std::numeric_limits<int>::max();
  int second = std::numeric_limits<int>::max();
  int best_index = -1;
  int best_octave = -1;
  int second_octave = -1;
  std::int64_t best_rank = std::numeric_limits<std::int64_t>::max();
  std::int64_t second_rank = std::numeric_limits<std::int64_t>::max();

  void Offer(int index, int distance, int octave, std::int64_t rank) {
    if (distance < best || (distance == best && rank < best_rank)) {
      second = best;
      second_octave = best_octave;
      second_rank = best_rank;
      best = distance;
      best_index = index;
      best_octave = octave;
      best_rank = rank;
    } else if (distance < second || (distance == second && rank < second_rank)) {
      second = distance;
      second_octave = octave;
      second_rank = rank;
    }
  }
};

}  // namespace

int MatchByProjection(const std::vector<ProjectionCandidate>& candidates,
                      const Rigid3d& cam_from_world, const ProjectionMatchOptions& options,
                      Frame* frame, ProjectionMatchScratch* scratch) {
  const Camera& camera = *frame->camera;
  const int num_keypoints = frame->num_keypoints();
  const int num_candidates = static_cast<int>(candidates.size());
  auto& best_distance = scratch->best_distance_per_keypoint;
  auto& winner = scratch->candidate_per_keypoint;
  best_distance.assign(num_keypoints, std::numeric_limits<int>::max());
  winner.assign(num_keypoints, -1);
  // An unprepared frame (no grid) has no keypoint to find, as KeypointGrid::Query says.
  if (num_keypoints == 0 || num_candidates == 0 || frame->grid.empty()) return 0;

  const Eigen::Matrix3d R = cam_from_world.RotationMatrix();
  const Eigen::Vector3d& t = cam_from_world.translation;
  const double cos_max_view = std::cos(std::min(camera.MaxViewAngle(), M_PI));
  // Free: no landmark, or an outlier's. Rank: the place in KeypointGrid::Query's order.
  const bool use_cells = options.search_cell_px > 0;
  const FreeKeypointCells& cells = scratch->free_cells;
  if (use_cells) {
    scratch->free_cells.Build(*frame, options.search_cell_px, [&](int i) {
      return frame->landmark_ids[i] == kInvalidId || frame->is_outlier[i];
    });
    scratch->cell_rank.resize(cells.num_slots());
    for (int k = 0; k < cells.num_slots(); ++k) {
      const int i = cells.keypoint[k];
      scratch->cell_rank[k] = static_cast<std::int64_t>(frame->grid.CellOf(i)) * num_keypoints + i;
    }
  }

  // Phase 1, per candidate (independent of the others: the frame's matches are only written in
  // phase 2, so it runs on the workers): its best keypoint if it passes the tests.
  const auto search = [&](const ProjectionCandidate& candidate, std::vector<int>* window) {
    ProjectionCandidateBest out;
    const Eigen::Vector3d p_in_cam = R * candidate.position_in_world + t;
    const double norm = p_in_cam.norm();
    if (!(norm > 0.0) || p_in_cam.z() / norm < cos_max_view - 1e-12) return out;
    const std::optional<Eigen::Vector2d> px = camera.Project(p_in_cam);
    if (!px || !camera.InImage(*px, options.image_margin_px)) return out;
    const float x = static_cast<float>(px->x()), y = static_cast<float>(px->y());
    BestTwo best;
    if (use_cells) {
      cells.ForEachInWindow(x, y, candidate.radius_px, [&](int k) {
        const int octave = cells.octave[k];
        if (octave < candidate.min_octave ||
            (candidate.max_octave >= 0 && octave > candidate.max_octave)) {
          return;
        }
        best.Offer(cells.keypoint[k], HammingDistance(candidate.descriptor, cells.descriptor[k]),
                   octave, scratch->cell_rank[k]);
      });
    } else {
      frame->grid.Query(frame->keypoints, x, y, candidate.radius_px, candidate.min_octave,
                        candidate.max_octave, window);
      std::int64_t rank = 0;  // the query's own order
      for (const int i : *window) {
        if (frame->landmark_ids[i] != kInvalidId && !frame->is_outlier[i]) continue;
        best.Offer(i, HammingDistance(candidate.descriptor, frame->descriptors[i]),
                   frame->keypoints[i].octave, rank++);
      }
    }
    if (best.best_index < 0 || best.best > options.max_hamming_distance) return out;
    // Ratio test only between keypoints of the same octave (ORB-SLAM): different octaves of
    // one corner legitimately look alike.
    if (best.second_octave == best.best_octave && best.best > options.ratio * best.second) {
      return out;
    }
    out.distance = best.best;
    out.keypoint = best.best_index;
    return out;
  };
  scratch->per_candidate.resize(num_candidates);
  const bool parallel = use_cells && options.num_threads > 1;
  if (parallel) {
    if (!scratch->pool || scratch->pool->num_threads() != options.num_threads) {
      scratch->pool = std::make_unique<ParallelFor>(options.num_threads);
    }
    // Chunks of 32 candidates: a candidate costs a projection and a few Hamming distances.
    scratch->pool->Run(num_candidates, 32, [&](int begin, int end, int /*worker*/) {
      for (int c = begin; c < end; ++c) scratch->per_candidate[c] = search(candidates[c], nullptr);
    });
  } else {
    for (int c = 0; c < num_candidates; ++c) {
      scratch->per_candidate[c] = search(candidates[c], &scratch->window);
    }
  }

  // Phase 2, in candidate order: when two candidates pick the same keypoint, the closer
  // descriptor wins (the first one on a tie).
  for (int c = 0; c < num_candidates; ++c) {
    const ProjectionCandidateBest& found = scratch->per_candidate[c];
    if (found.keypoint < 0) continue;
    if (found.distance < best_distance[found.keypoint]) {
      best_distance[found.keypoint] = found.distance;
      winner[found.keypoint] = c;
    }
  }

  // Orientation consistency among the winners that carry a reference angle.
  std::vector<unsigned char> keep_bin;
  if (options.check_orientation) {
    auto& bins = scratch->rotation_bins;
    bins.resize(options.orientation_bins);
    for (auto& b : bins) b.clear();
    for (int i = 0; i < num_keypoints; ++i) {
      if (winner[i] < 0) continue;
      const ProjectionCandidate& candidate = candidates[winner[i]];
      if (candidate.reference_angle_deg < 0.f || frame->keypoints[i].angle_deg < 0.f) continue;
      bins[RotationBin(candidate.reference_angle_deg, frame->keypoints[i].angle_deg,
                       options.orientation_bins)]
          .push_back(i);
    }
    keep_bin = DominantRotationBins(bins);
  }

  int num_matches = 0;
  for (int i = 0; i < num_keypoints; ++i) {
    if (winner[i] < 0) continue;
    const ProjectionCandidate& candidate = candidates[winner[i]];
    if (options.check_orientation && candidate.reference_angle_deg >= 0.f &&
        frame->keypoints[i].angle_deg >= 0.f &&
        !keep_bin[RotationBin(candidate.reference_angle_deg, frame->keypoints[i].angle_deg,
                              options.orientation_bins)]) {
      continue;
    }
    frame->landmark_ids[i] = candidate.landmark_id;
    frame->is_outlier[i] = 0;
    ++num_matches;
  }
  return num_matches;
}

}  // namespace lcv::slam
