#include "slam/solve/two_view.h"

#include <algorithm>
#include <cmath>
#include <functional>

#include "slam/solve/bearing_error.h"
#include "slam/solve/essential.h"
#include "slam/solve/homography.h"
#include "slam/solve/triangulation.h"

namespace lcv::slam {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegToRad = kPi / 180.0;
// Chi-square 95% quantiles (ORB-SLAM's Initializer): 1 dof for the epipolar distance, 2 dof
// for the transfer error; the score bonus Gamma uses the 2-dof value for both models.
constexpr double kChi2OneDof = 3.841;
constexpr double kChi2TwoDof = 5.991;

// ORB-SLAM's model score: sum over the data of (Gamma - r^2 / sigma^2) where below threshold.
double ModelScore(const std::vector<double>& squared_residuals, double sigma_sq,
                  double chi2_threshold) {
  double score = 0.0;
  for (const double r2 : squared_residuals) {
    const double normalized = r2 / sigma_sq;
    if (normalized < chi2_threshold) score += kChi2TwoDof - normalized;
  }
  return score;
}

struct MotionCheck {
  Rigid3d cam2_from_cam1;
  int num_good = 0;           // positive depth and small reprojection error
  int num_triangulated = 0;   // good and enough parallax
  double median_parallax_deg = 0.0;
  double ranked_parallax_deg = 0.0;  // the options.parallax_rank-th largest
  std::vector<char> triangulated;
  std::vector<Eigen::Vector3d> points_in_cam1;
};

// Triangulates the inliers under a candidate motion and counts the points that are in front
// of both cameras and reproject within the threshold (ORB-SLAM's CheckRT, on bearings).
MotionCheck CheckMotion(const Eigen::Matrix3d& R, const Eigen::Vector3d& t_raw,
                        const std::vector<Eigen::Vector3d>& bearings1,
                        const std::vector<Eigen::Vector3d>& bearings2,
                        const std::vector<char>& inliers, const TwoViewOptions& options,
                        std::vector<double>* parallax_scratch) {
  MotionCheck check;
  const int n = static_cast<int>(bearings1.size());
  Eigen::Quaterniond q(R);
  q.normalize();
  check.cam2_from_cam1 = Rigid3d(q, t_raw.normalized());
  check.triangulated.assign(n, 0);
  check.points_in_cam1.assign(n, Eigen::Vector3d::Zero());
  const Rigid3d identity;
  const double max_error_sq = options.max_angular_error_rad * options.max_angular_error_rad;
  const double min_parallax_rad = options.min_point_parallax_deg * kDegToRad;
  parallax_scratch->clear();
  for (int i = 0; i < n; ++i) {
    if (!inliers[i]) continue;
    const auto point = TriangulateBearings(identity, check.cam2_from_cam1, bearings1[i],
                                           bearings2[i]);
    if (!point) continue;
    const Eigen::Vector3d& p1 = point->point_in_world;
    const Eigen::Vector3d p2 = check.cam2_from_cam1 * p1;
    if (SquaredChordError(bearings1[i], p1) > max_error_sq ||
        SquaredChordError(bearings2[i], p2) > max_error_sq) {
      continue;
    }
    ++check.num_good;
    parallax_scratch->push_back(point->parallax_rad);
    if (point->parallax_rad >= min_parallax_rad) {
      check.triangulated[i] = 1;
      check.points_in_cam1[i] = p1;
      ++check.num_triangulated;
    }
  }
  if (!parallax_scratch->empty()) {
    auto middle = parallax_scratch->begin() + parallax_scratch->size() / 2;
    std::nth_element(parallax_scratch->begin(), middle, parallax_scratch->end());
    check.median_parallax_deg = *middle / kDegToRad;
    // Fewer good points than the rank: the gate cannot be met (0).
    if (static_cast<int>(parallax_scratch->size()) >= options.parallax_rank) {
      auto ranked = parallax_scratch->begin() + (options.parallax_rank - 1);
      std::nth_element(parallax_scratch->begin(), ranked, parallax_scratch->end(),
                       std::greater<double>());
      check.ranked_parallax_deg = *ranked / kDegToRad;
    }
  }
  return check;
}

}  // namespace

std::optional<std::string> TwoViewOptions::Problem() const {
  if (!(max_angular_error_rad > 0.0)) return "max_angular_error_rad must be > 0";
  if (!(min_point_parallax_deg >= 0.0)) return "min_point_parallax_deg must be >= 0";
  if (!(parallax_threshold_deg >= 0.0)) return "parallax_threshold_deg must be >= 0";
  if (parallax_rank < 1) return "parallax_rank must be >= 1";
  if (min_num_triangulated < 1) return "min_num_triangulated must be >= 1";
  if (!(min_triangulated_ratio >= 0.0 && min_triangulated_ratio <= 1.0))
    return "min_triangulated_ratio must be in [0, 1]";
  if (!(max_ambiguity_ratio > 0.0 && max_ambiguity_ratio <= 1.0))
    return "max_ambiguity_ratio must be in (0, 1]";
  if (!(max_homography_ambiguity_ratio > 0.0 && max_homography_ambiguity_ratio <= 1.0))
    return "max_homography_ambiguity_ratio must be in (0, 1]";
  if (!(homography_ratio >= 0.0 && homography_ratio <= 1.0))
    return "homography_ratio must be in [0, 1]";
  if (max_ransac_trials < 1) return "max_ransac_trials must be >= 1";
  if (max_homography_trials < 1) return "max_homography_trials must be >= 1";
  return std::nullopt;
}

void TwoViewOptions::Check() const {
  const auto problem = Problem();
  LCV_CHECK(!problem) << *problem;
}

TwoViewGeometry EstimateTwoViewGeometry(const std::vector<Eigen::Vector3d>& bearings1,
                                        const std::vector<Eigen::Vector3d>& bearings2,
                                        const TwoViewOptions& options) {
  options.Check();
  LCV_CHECK(bearings1.size() == bearings2.size())
      << bearings1.size() << " vs " << bearings2.size() << " bearings";
  TwoViewGeometry result;
  const int n = static_cast<int>(bearings1.size());
  if (n < EssentialMatrixEstimator::kMinNumSamples) {
    result.reason = "too few correspondences: " + std::to_string(n);
    return result;
  }
  const double sigma_sq = options.max_angular_error_rad * options.max_angular_error_rad /
                          kChi2TwoDof;

  // Essential matrix, threshold at the 1-dof quantile.
  RansacOptions ransac;
  ransac.max_error = std::sqrt(kChi2OneDof * sigma_sq);
  ransac.max_num_trials = options.max_ransac_trials;
  ransac.random_seed = options.random_seed;
  ransac.min_inlier_ratio = 0.0;
  const EssentialMatrixEstimator essential_estimator(bearings1.data(), bearings2.data(), n);
  const RansacReport<Eigen::Matrix3d> essential = Ransac(ransac, essential_estimator);
  std::vector<double> residuals;
  double score_E = 0.0;
  if (essential.success) {
    essential_estimator.Residuals(essential.model, &residuals);
    score_E = ModelScore(residuals, sigma_sq, kChi2OneDof);
  }

  // Homography on normalized coordinates of the pairs in front of both cameras.
  RansacReport<Eigen::Matrix3d> homography;
  double score_H = 0.0;
  std::vector<char> homography_inliers;
  if (options.use_homography) {
    std::vector<int> usable;
    std::vector<Eigen::Vector2d> u1, u2;
    usable.reserve(n);
    u1.reserve(n);
    u2.reserve(n);
    for (int i = 0; i < n; ++i) {
      // Bearings more than ~84 degrees off-axis have no useful normalized coordinates.
      if (bearings1[i].z() > 0.1 * bearings1[i].norm() &&
          bearings2[i].z() > 0.1 * bearings2[i].norm()) {
        usable.push_back(i);
        u1.push_back(bearings1[i].hnormalized());
        u2.push_back(bearings2[i].hnormalized());
      }
    }
    if (static_cast<int>(usable.size()) >= HomographyEstimator::kMinNumSamples) {
      RansacOptions h_ransac = ransac;
      h_ransac.max_error = std::sqrt(kChi2TwoDof * sigma_sq);
      h_ransac.max_num_trials = options.max_homography_trials;
      const HomographyEstimator homography_estimator(u1.data(), u2.data(),
                                                     static_cast<int>(usable.size()));
      homography = Ransac(h_ransac, homography_estimator);
      if (homography.success) {
        homography_estimator.Residuals(homography.model, &residuals);
        score_H = ModelScore(residuals, sigma_sq, kChi2TwoDof);
        homography_inliers.assign(n, 0);
        for (size_t k = 0; k < usable.size(); ++k) {
          homography_inliers[usable[k]] = homography.inlier_mask[k];
        }
      }
    }
  }

  if (score_E <= 0.0 && score_H <= 0.0) {
    result.reason = "no epipolar or homography model found";
    return result;
  }
  const bool pick_homography =
      score_H > 0.0 && score_H / (score_H + score_E) > options.homography_ratio;

  // Candidate motions of the chosen model.
  std::vector<std::pair<Eigen::Matrix3d, Eigen::Vector3d>> candidates;
  const std::vector<char>* inliers = nullptr;
  std::vector<char> essential_inliers;
  if (pick_homography) {
    std::vector<HomographyMotion> motions;
    DecomposeHomography(homography.model, &motions);
    for (const auto& motion : motions) {
      if (motion.t.norm() > 1e-12) candidates.emplace_back(motion.R, motion.t);
    }
    inliers = &homography_inliers;
    result.model = TwoViewGeometry::Model::kHomography;
  } else {
    // Refine the linear E on its inliers to the geometric (epipolar angle) error, then re-select
    // the inliers with the refined E.
    essential_inliers = essential.inlier_mask;
    Eigen::Matrix3d E = essential.model;
    Rigid3d pose;
    if (PoseFromEssentialMatrix(E, bearings1.data(), bearings2.data(), n,
                                essential_inliers.data(), &pose) > 0) {
      std::vector<int> indices;
      for (int i = 0; i < n; ++i) {
        if (essential_inliers[i]) indices.push_back(i);
      }
      if (RefineRelativePose(bearings1.data(), bearings2.data(), n, &indices, 10, &pose) >= 0) {
        E = SkewSymmetric(pose.translation) * pose.RotationMatrix();
        essential_estimator.Residuals(E, &residuals);
        const double threshold_sq = ransac.max_error * ransac.max_error;
        for (int i = 0; i < n; ++i) essential_inliers[i] = residuals[i] <= threshold_sq;
      }
    }
    Eigen::Matrix3d R1, R2;
    Eigen::Vector3d t;
    DecomposeEssentialMatrix(E, &R1, &R2, &t);
    candidates = {{R1, t}, {R1, -t}, {R2, t}, {R2, -t}};
    inliers = &essential_inliers;
    result.model = TwoViewGeometry::Model::kEssential;
  }
  result.inlier_mask = *inliers;
  result.num_inliers = static_cast<int>(std::count(inliers->begin(), inliers->end(), 1));
  if (candidates.empty()) {
    result.reason = "homography decomposition degenerate (no translation?)";
    return result;
  }

  std::vector<double> parallax_scratch;
  MotionCheck best;
  int second_best_good = 0;
  for (const auto& [R, t] : candidates) {
    MotionCheck check = CheckMotion(R, t, bearings1, bearings2, *inliers, options,
                                    &parallax_scratch);
    if (check.num_good > best.num_good) {
      second_best_good = best.num_good;
      best = std::move(check);
    } else if (check.num_good > second_best_good) {
      second_best_good = check.num_good;
    }
  }

  result.num_triangulated = best.num_triangulated;
  result.median_parallax_deg = best.median_parallax_deg;
  result.ranked_parallax_deg = best.ranked_parallax_deg;
  if (best.num_triangulated < options.min_num_triangulated) {
    result.reason = "too few triangulated points: " + std::to_string(best.num_triangulated) +
                    " < " + std::to_string(options.min_num_triangulated);
    return result;
  }
  if (best.num_good < options.min_triangulated_ratio * result.num_inliers) {
    result.reason = "only " + std::to_string(best.num_good) + " of " +
                    std::to_string(result.num_inliers) + " inliers triangulate";
    return result;
  }
  const double ambiguity_ratio = pick_homography ? options.max_homography_ambiguity_ratio
                                                 : options.max_ambiguity_ratio;
  if (second_best_good >= ambiguity_ratio * best.num_good) {
    result.reason = "ambiguous motion: second best triangulates " +
                    std::to_string(second_best_good) + " vs " + std::to_string(best.num_good);
    return result;
  }
  if (best.ranked_parallax_deg < options.parallax_threshold_deg) {
    result.reason = "too little parallax: point " + std::to_string(options.parallax_rank) +
                    " by parallax has " + std::to_string(best.ranked_parallax_deg) + " deg";
    return result;
  }
  result.success = true;
  result.cam2_from_cam1 = best.cam2_from_cam1;
  result.triangulated = std::move(best.triangulated);
  result.points_in_cam1 = std::move(best.points_in_cam1);
  return result;
}

}  // namespace lcv::slam
