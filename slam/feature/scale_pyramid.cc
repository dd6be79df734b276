#include "slam/feature/scale_pyramid.h"

#include <algorithm>
#include <cmath>

namespace lcv::slam {

float ScalePyramid::Scale(int level) const {
  return std::pow(scale_factor, static_cast<float>(level));
}

float ScalePyramid::Sigma2(int level) const {
  const float scale = Scale(level);
  return scale * scale;
}

std::vector<float> ScalePyramid::Scales() const {
  std::vector<float> out(num_levels);
  for (int l = 0; l < num_levels; ++l) out[l] = Scale(l);
  return out;
}

std::vector<float> ScalePyramid::Sigma2s() const {
  std::vector<float> out(num_levels);
  for (int l = 0; l < num_levels; ++l) out[l] = Sigma2(l);
  return out;
}

int ScalePyramid::PredictLevel(double distance, double reference_distance,
                               int reference_level) const {
  // A feature seen from farther away appears smaller, i.e. at a finer (lower) level: the level
  // changes by log_scale(reference_distance / distance) relative to the reference level.
  if (!(distance > 0.0) || !(reference_distance > 0.0)) return std::clamp(reference_level, 0, num_levels - 1);
  const double ratio = reference_distance / distance;
  const int level = reference_level +
                    static_cast<int>(std::ceil(std::log(ratio) / std::log(scale_factor)));
  return std::clamp(level, 0, num_levels - 1);
}

}  // namespace lcv::slam
