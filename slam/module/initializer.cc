#include "slam/module/initializer.h"

#include <string>

namespace lcv::slam {

Initializer::Initializer(const InitializerOptions& options) : options_(options) {
  options_.two_view.Check();
}

void Initializer::SetReference(const Frame& frame) {
  reference_ = frame;
  has_reference_ = true;
  predicted_px_.clear();
  reference_age_frames_ = 0;
}

std::optional<Initialization> Initializer::TryInitialize(const Frame& current) {
  if (!has_reference_) {
    SetReference(current);
    last_failure_ = "first reference frame";
    return std::nullopt;
  }
  ++reference_age_frames_;
  std::vector<int> matches;
  const int num_matches =
      MatchInWindow(reference_, current, options_.matching, &predicted_px_, &matches);
  if (num_matches < options_.min_matches ||
      reference_age_frames_ > options_.max_reference_age_frames) {
    last_failure_ = "too few matches with the reference (" + std::to_string(num_matches) + " < " +
                    std::to_string(options_.min_matches) + "), or reference too old: restarting";
    SetReference(current);
    return std::nullopt;
  }

  std::vector<Eigen::Vector3d> bearings1, bearings2;
  std::vector<std::pair<int, int>> pairs;
  bearings1.reserve(num_matches);
  bearings2.reserve(num_matches);
  for (int i1 = 0; i1 < static_cast<int>(matches.size()); ++i1) {
    const int i2 = matches[i1];
    if (i2 < 0) continue;
    const Eigen::Vector3d& b1 = reference_.bearings[i1];
    const Eigen::Vector3d& b2 = current.bearings[i2];
    if (b1.squaredNorm() < 0.5 || b2.squaredNorm() < 0.5) continue;
    bearings1.push_back(b1);
    bearings2.push_back(b2);
    pairs.emplace_back(i1, i2);
  }
  TwoViewOptions two_view = options_.two_view;
  two_view.random_seed = options_.seed + attempts_++;
  two_view.use_homography =
      options_.two_view.use_homography && current.camera->model() == CameraModel::kPerspective;
  const TwoViewGeometry geometry = EstimateTwoViewGeometry(bearings1, bearings2, two_view);
  if (!geometry.success) {
    last_failure_ = "two-view geometry: " + geometry.reason;
    return std::nullopt;
  }
  Initialization result;
  result.current_from_reference = geometry.cam2_from_cam1;
  result.from_homography = geometry.model == TwoViewGeometry::Model::kHomography;
  for (size_t k = 0; k < pairs.size(); ++k) {
    if (!geometry.triangulated[k]) continue;
    result.matches.push_back(pairs[k]);
    result.points_in_reference.push_back(geometry.points_in_cam1[k]);
  }
  last_failure_.clear();
  return result;
}

}  // namespace lcv::slam
