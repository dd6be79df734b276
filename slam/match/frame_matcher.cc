#include "slam/match/frame_matcher.h"

#include <algorithm>
#include <cstdlib>

#include "slam/match/projection_matcher.h"  // RotationBin, DominantRotationBins

namespace lcv::slam {

std::vector<std::pair<int, int>> MatchFramesByDescriptor(const Frame& a, const Frame& b,
                                                         const FrameMatchOptions& options) {
  const int na = a.num_keypoints(), nb = b.num_keypoints();
  std::vector<int> nearest_in_b(na, -1);
  // Per keypoint of b: its nearest keypoint of a and that distance (for the mutual check).
  std::vector<int> b_best(nb, NearestTwo::kNone);
  std::vector<int> b_best_index(nb, -1);
  for (int i = 0; i < na; ++i) {
    if (a.bearings[i].squaredNorm() < 0.5) continue;
    NearestTwo nearest;
    for (int j = 0; j < nb; ++j) {
      if (std::abs(a.keypoints[i].octave - b.keypoints[j].octave) >
          options.max_octave_difference) {
        continue;
      }
      const int d = HammingDistance(a.descriptors[i], b.descriptors[j]);
      nearest.Offer(d, j);
      if (d < b_best[j]) {
        b_best[j] = d;
        b_best_index[j] = i;
      }
    }
    const int best = nearest.best, second = nearest.second, best_j = nearest.index;
    if (best_j < 0 || best > options.max_hamming_distance) continue;
    if (second != NearestTwo::kNone && !(best < options.ratio * second)) continue;
    nearest_in_b[i] = best_j;
  }
  std::vector<std::pair<int, int>> pairs;
  const int num_bins = std::max(1, options.orientation_bins);
  std::vector<std::vector<int>> bins(num_bins);
  for (int i = 0; i < na; ++i) {
    const int j = nearest_in_b[i];
    if (j < 0 || b_best_index[j] != i || b.bearings[j].squaredNorm() < 0.5) continue;
    if (!options.check_orientation) {
      pairs.emplace_back(i, j);
      continue;
    }
    bins[RotationBin(a.keypoints[i].angle_deg, b.keypoints[j].angle_deg, num_bins)].push_back(i);
  }
  if (options.check_orientation) {
    const std::vector<unsigned char> dominant = DominantRotationBins(bins);
    for (size_t bin = 0; bin < bins.size(); ++bin) {
      if (!dominant[bin]) continue;
      for (const int i : bins[bin]) pairs.emplace_back(i, nearest_in_b[i]);
    }
    std::sort(pairs.begin(), pairs.end());
  }
  return pairs;
}

}  // namespace lcv::slam
