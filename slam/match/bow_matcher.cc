#include "slam/match/bow_matcher.h"

#include <algorithm>

#include "slam/bow/direct_index_matcher.h"
#include "slam/match/projection_matcher.h"
#include "slam/util/error.h"

namespace lcv::slam {

int MatchKeyframeLandmarksByBow(const SlamKeyframe& keyframe, const Frame& frame,
                                const BowMatchOptions& options,
                                std::vector<BowLandmarkMatch>* matches) {
  LCV_CHECK(matches != nullptr);
  LCV_CHECK(options.orientation_bins > 0);
  matches->clear();
  // The keyframe's direct index restricted to keypoints with a landmark, so that only those
  // are matched (the frame side keeps every keypoint for the ratio test).
  DirectIndex with_landmarks;
  with_landmarks.reserve(keyframe.direct_index.size());
  for (const DirectIndexEntry& entry : keyframe.direct_index) {
    DirectIndexEntry kept{entry.node, {}};
    for (const int i : entry.features) {
      if (i >= 0 && i < static_cast<int>(keyframe.landmark_ids.size()) &&
          keyframe.landmark_ids[i] != kInvalidId) {
        kept.features.push_back(i);
      }
    }
    if (!kept.features.empty()) with_landmarks.push_back(std::move(kept));
  }
  DirectIndexMatchOptions descriptor_options;
  descriptor_options.max_distance = options.max_distance;
  descriptor_options.ratio = options.ratio;
  std::vector<DescriptorMatch> descriptor_matches;
  MatchByDirectIndex(with_landmarks, keyframe.descriptors, frame.direct_index, frame.descriptors,
                     descriptor_options, &descriptor_matches);

  std::vector<unsigned char> keep(descriptor_matches.size(), 1);
  if (options.check_orientation) {
    std::vector<std::vector<int>> bins(options.orientation_bins);
    for (std::size_t k = 0; k < descriptor_matches.size(); ++k) {
      const float from = keyframe.keypoints[descriptor_matches[k].index_a].angle_deg;
      const float to = frame.keypoints[descriptor_matches[k].index_b].angle_deg;
      if (from < 0.f || to < 0.f) continue;
      bins[RotationBin(from, to, options.orientation_bins)].push_back(static_cast<int>(k));
    }
    const std::vector<unsigned char> dominant = DominantRotationBins(bins);
    for (int b = 0; b < options.orientation_bins; ++b) {
      if (dominant[b]) continue;
      for (const int k : bins[b]) keep[k] = 0;
    }
  }
  for (std::size_t k = 0; k < descriptor_matches.size(); ++k) {
    if (!keep[k]) continue;
    const DescriptorMatch& m = descriptor_matches[k];
    matches->push_back({m.index_b, keyframe.landmark_ids[m.index_a], m.distance});
  }
  std::sort(matches->begin(), matches->end(),
            [](const BowLandmarkMatch& x, const BowLandmarkMatch& y) {
              return x.frame_keypoint < y.frame_keypoint;
            });
  return static_cast<int>(matches->size());
}

}  // namespace lcv::slam
