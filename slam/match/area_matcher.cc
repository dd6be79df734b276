#include "slam/match/area_matcher.h"

#include <limits>

#include "slam/match/projection_matcher.h"

namespace lcv::slam {

int MatchInWindow(const Frame& reference, const Frame& current, const AreaMatchOptions& options,
                  std::vector<Eigen::Vector2f>* predicted_px, std::vector<int>* matches) {
  const int n1 = reference.num_keypoints();
  const int n2 = current.num_keypoints();
  if (static_cast<int>(predicted_px->size()) != n1) {
    predicted_px->resize(n1);
    for (int i = 0; i < n1; ++i) {
      (*predicted_px)[i] = Eigen::Vector2f(reference.keypoints[i].x, reference.keypoints[i].y);
    }
  }
  matches->assign(n1, -1);
  std::vector<int> matched_by(n2, -1);
  std::vector<int> matched_distance(n2, std::numeric_limits<int>::max());
  std::vector<std::vector<int>> bins(options.orientation_bins);
  std::vector<int> window;
  int num_matches = 0;

  for (int i1 = 0; i1 < n1; ++i1) {
    const Keypoint& kp1 = reference.keypoints[i1];
    if (kp1.octave > options.max_octave) continue;
    const Eigen::Vector2f& center = (*predicted_px)[i1];
    current.grid.Query(current.keypoints, center.x(), center.y(), options.window_px, 0,
                       options.max_octave, &window);
    NearestTwo nearest;
    for (const int i2 : window) {
      const int d = HammingDistance(reference.descriptors[i1], current.descriptors[i2]);
      if (matched_distance[i2] <= d) continue;
      nearest.Offer(d, i2);
    }
    const int best = nearest.best, second = nearest.second, best_index = nearest.index;
    if (best_index < 0 || best > options.max_hamming_distance) continue;
    if (best >= options.ratio * second) continue;
    if (matched_by[best_index] >= 0) {
      (*matches)[matched_by[best_index]] = -1;
      --num_matches;
    }
    (*matches)[i1] = best_index;
    matched_by[best_index] = i1;
    matched_distance[best_index] = best;
    ++num_matches;
  }

  if (options.check_orientation) {
    for (int i1 = 0; i1 < n1; ++i1) {
      const int i2 = (*matches)[i1];
      if (i2 < 0) continue;
      const float a1 = reference.keypoints[i1].angle_deg;
      const float a2 = current.keypoints[i2].angle_deg;
      if (a1 < 0.f || a2 < 0.f) continue;
      bins[RotationBin(a1, a2, options.orientation_bins)].push_back(i1);
    }
    const std::vector<unsigned char> keep = DominantRotationBins(bins);
    for (int b = 0; b < options.orientation_bins; ++b) {
      if (keep[b]) continue;
      for (const int i1 : bins[b]) {
        (*matches)[i1] = -1;
        --num_matches;
      }
    }
  }

  for (int i1 = 0; i1 < n1; ++i1) {
    const int i2 = (*matches)[i1];
    if (i2 >= 0) (*predicted_px)[i1] = Eigen::Vector2f(current.keypoints[i2].x, current.keypoints[i2].y);
  }
  return num_matches;
}

}  // namespace lcv::slam
