#include "slam/match/projection_matcher.h"

#include <algorithm>
#include <cmath>
#include <limits>

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

int MatchByProjection(const std::vector<ProjectionCandidate>& candidates,
                      const Rigid3d& cam_from_world, const ProjectionMatchOptions& options,
                      Frame* frame, ProjectionMatchScratch* scratch) {
  const Camera& camera = *frame->camera;
  const int num_keypoints = frame->num_keypoints();
  auto& best_distance = scratch->best_distance_per_keypoint;
  auto& winner = scratch->candidate_per_keypoint;
  best_distance.assign(num_keypoints, std::numeric_limits<int>::max());
  winner.assign(num_keypoints, -1);

  const Eigen::Matrix3d R = cam_from_world.RotationMatrix();
  const Eigen::Vector3d& t = cam_from_world.translation;
  const double cos_max_view = std::cos(std::min(camera.MaxViewAngle(), M_PI));

  for (int c = 0; c < static_cast<int>(candidates.size()); ++c) {
    const ProjectionCandidate& candidate = candidates[c];
    const Eigen::Vector3d p_in_cam = R * candidate.position_in_world + t;
    const double norm = p_in_cam.norm();
    if (!(norm > 0.0) || p_in_cam.z() / norm < cos_max_view - 1e-12) continue;
    const std::optional<Eigen::Vector2d> px = camera.Project(p_in_cam);
    if (!px || !camera.InImage(*px, options.image_margin_px)) continue;

    frame->grid.Query(frame->keypoints, static_cast<float>(px->x()), static_cast<float>(px->y()),
                      candidate.radius_px, candidate.min_octave, candidate.max_octave,
                      &scratch->window);
    int best = std::numeric_limits<int>::max();
    int second = std::numeric_limits<int>::max();
    int best_index = -1;
    int best_octave = -1;
    int second_octave = -1;
    for (const int i : scratch->window) {
      if (frame->landmark_ids[i] != kInvalidId && !frame->is_outlier[i]) continue;
      const int d = HammingDistance(candidate.descriptor, frame->descriptors[i]);
      if (d < best) {
        second = best;
        second_octave = best_octave;
        best = d;
        best_index = i;
        best_octave = frame->keypoints[i].octave;
      } else if (d < second) {
        second = d;
        second_octave = frame->keypoints[i].octave;
      }
    }
    if (best_index < 0 || best > options.max_hamming_distance) continue;
    // Ratio test only between keypoints of the same octave (ORB-SLAM): different octaves of
    // one corner legitimately look alike.
    if (second_octave == best_octave && best > options.ratio * second) continue;
    if (best < best_distance[best_index]) {
      best_distance[best_index] = best;
      winner[best_index] = c;
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
