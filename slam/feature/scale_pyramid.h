#pragma once
// Scale factors of an image pyramid, shared by the ORB extractor (which builds the images), the
// matchers (search radius grows with the level) and the BA (residual weight 1 / sigma^2 per
// level). No OpenCV here, so data/ and optimize/ can use it.
//
// Level l is the image scaled down by scale_factor^l: a keypoint at level l has pixel
// uncertainty sigma_l = scale_factor^l (in level-0 pixels), hence information 1 / sigma_l^2.

#include <vector>

namespace lcv::slam {

struct ScalePyramid {
  float scale_factor = 1.2f;
  int num_levels = 8;

  ScalePyramid() = default;
  ScalePyramid(float factor, int levels) : scale_factor(factor), num_levels(levels) {}

  // scale_factor^level (>= 1).
  float Scale(int level) const;
  // scale_factor^(2 level): the variance (px^2 at level 0) of a keypoint at that level.
  float Sigma2(int level) const;
  float InvSigma2(int level) const { return 1.f / Sigma2(level); }
  // All of them, index = level.
  std::vector<float> Scales() const;
  std::vector<float> Sigma2s() const;
  // Level a feature seen at distance `distance` should appear at, given that it was seen at
  // `reference_level` from `reference_distance` (ORB-SLAM's PredictScale), clamped to
  // [0, num_levels - 1].
  int PredictLevel(double distance, double reference_distance, int reference_level) const;
};

}  // namespace lcv::slam
