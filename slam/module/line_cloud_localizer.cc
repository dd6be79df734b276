#include "slam/module/line_cloud_localizer.h"

#include <cmath>
#include <limits>
#include <map>

#include "slam/solve/p3l_known_rotation.h"
#include "slam/util/error.h"

namespace lcv::slam {
namespace {

constexpr double kTwoPi = 6.283185307179586;

// Focal length in pixels that converts a pixel error into an angle (bearing_error.h).
double FocalPx(const Camera& camera) {
  const CameraParams& p = camera.params();
  if (p.model == CameraModel::kEquirectangular) return p.cols / kTwoPi;
  return 0.5 * (p.fx + p.fy);
}

}  // namespace

std::string LineCloudLocalizerOptions::Problem() const {
  if (max_hamming_distance < 0 || max_hamming_distance > 256)
    return "max_hamming_distance must be in [0, 256]";
  if (!(ratio > 0.0 && ratio <= 1.0)) return "ratio must be in (0, 1]";
  if (!(max_error_px > 0.0)) return "max_error_px must be > 0";
  if (min_num_matches < 6) return "min_num_matches must be >= 6 (p6L's minimal sample)";
  if (min_num_inliers < 6) return "min_num_inliers must be >= 6 (p6L's minimal sample)";
  if (max_ransac_trials < 1) return "max_ransac_trials must be >= 1";
  if (max_rotation_prior_trials < 1) return "max_rotation_prior_trials must be >= 1";
  if (min_rotation_prior_inliers < 1) return "min_rotation_prior_inliers must be >= 1";
  return "";
}

LineCloudLocalizer::LineCloudLocalizer(const Map& line_cloud, const Camera& camera,
                                       const LineCloudLocalizerOptions& options)
    : camera_(camera), options_(options) {
  const std::string problem = options.Problem();
  LCV_CHECK(problem.empty()) << problem;
  max_error_rad_ = options.max_error_px / FocalPx(camera);
  for (const auto& [id, line] : line_cloud.lines) {
    if (!line.descriptor) continue;
    line_ids_.push_back(id);
    lines_.push_back(line.line);
    descriptors_.push_back(*line.descriptor);
  }
}

LineCloudLocalization LineCloudLocalizer::Localize(
    const std::vector<Keypoint>& keypoints, const std::vector<OrbDescriptor>& descriptors,
    int max_ransac_trials, const std::function<bool()>& should_stop, std::uint64_t seed_offset,
    const std::optional<Eigen::Quaterniond>& rotation_prior) const {
  LCV_CHECK(keypoints.size() == descriptors.size()) << "one descriptor per keypoint";
  LineCloudLocalization result;
  result.num_features = static_cast<int>(keypoints.size());

  // 2-NN over the lines per feature; per line the closest feature that passes (one-to-one).
  struct Candidate {
    int keypoint = -1;
    int distance = std::numeric_limits<int>::max();
  };
  std::map<int, Candidate> best_per_line;  // line index -> feature
  for (int k = 0; k < static_cast<int>(descriptors.size()); ++k) {
    NearestTwo nearest;
    for (int j = 0; j < static_cast<int>(descriptors_.size()); ++j) {
      nearest.Offer(HammingDistance(descriptors[k], descriptors_[j]), j);
    }
    const int best = nearest.best, second = nearest.second, best_line = nearest.index;
    if (best_line < 0 || best > options_.max_hamming_distance) continue;
    if (second != NearestTwo::kNone && !(best < options_.ratio * second)) continue;
    Candidate& c = best_per_line[best_line];
    if (best < c.distance) c = {k, best};
  }

  std::vector<Eigen::Vector3d> bearings;
  std::vector<Line3d> lines;
  std::vector<std::pair<int, Id>> matches;
  for (const auto& [line_index, c] : best_per_line) {
    const Keypoint& kp = keypoints[c.keypoint];
    const auto bearing = camera_.Unproject(Eigen::Vector2d(kp.x, kp.y));
    if (!bearing) continue;
    bearings.push_back(bearing->normalized());
    lines.push_back(lines_[line_index]);
    matches.emplace_back(c.keypoint, line_ids_[line_index]);
  }
  result.num_matches = static_cast<int>(matches.size());
  if (result.num_matches < options_.min_num_matches) {
    result.failure = std::to_string(result.num_matches) + " matches < " +
                     std::to_string(options_.min_num_matches);
    return result;
  }
  if (should_stop && should_stop()) {
    result.stopped_early = true;
    result.failure = "stopped before RANSAC";
    return result;
  }

  // Keeps the pose and its inlier matches (mask over matches) as the result.
  auto succeed = [&](const Rigid3d& pose, const std::vector<char>& mask) {
    result.success = true;
    result.cam_from_world = pose;
    for (size_t i = 0; i < matches.size(); ++i) {
      if (!mask[i]) continue;
      result.inliers.push_back(matches[i]);
      result.inlier_bearings.push_back(bearings[i]);
      result.inlier_lines.push_back(lines[i]);
    }
    return result;
  };
  P6LOptions p6l;
  p6l.max_angular_error_rad = max_error_rad_;
  p6l.min_num_inliers = options_.min_num_inliers;
  p6l.ransac.max_num_trials =
      max_ransac_trials > 0 ? max_ransac_trials : options_.max_ransac_trials;
  p6l.ransac.random_seed = options_.random_seed + seed_offset;
  p6l.ransac.min_inlier_ratio = 0.0;  // the absolute count decides
  // Refine robustly: the RANSAC inliers of a wide threshold may still hold a few wrong matches.
  p6l.refinement.huber_threshold_rad = max_error_rad_;
  if (rotation_prior) {
    // The centre with the rotation held (thousands of samples cost what a few p6L ones do),
    // then all six degrees of freedom on its inliers.
    P6LOptions centre = p6l;
    centre.ransac.max_num_trials = options_.max_rotation_prior_trials;
    const P6LResult found = EstimatePoseKnownRotation(bearings, lines, *rotation_prior, centre);
    result.num_rotation_prior_trials = found.num_trials;
    if (found.success && found.num_inliers >= options_.min_rotation_prior_inliers) {
      result.num_inliers = found.num_inliers;
      result.from_rotation_prior = true;
      return succeed(found.cam_from_world, found.inlier_mask);
    }
    if (should_stop && should_stop()) {
      result.stopped_early = true;
      result.failure = "stopped after the rotation prior's search";
      return result;
    }
  }

  p6l.ransac.should_stop = should_stop;
  const P6LResult pose = EstimateP6L(bearings, lines, p6l);
  result.num_trials = pose.num_trials;
  result.num_inliers = pose.num_inliers;
  result.stopped_early = pose.stopped_early;
  if (!pose.success) {
    result.failure = pose.num_inliers > 0
                         ? std::to_string(pose.num_inliers) + " inliers < " +
                               std::to_string(options_.min_num_inliers)
                         : "RANSAC found no pose";
    return result;
  }
  return succeed(pose.cam_from_world, pose.inlier_mask);
}

}  // namespace lcv::slam
