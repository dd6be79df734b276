#include "slam/solve/absolute_pose.h"

#include <cmath>

#include <Eigen/Cholesky>

#include "slam/solve/bearing_error.h"
#include "slam/solve/p3p.h"

namespace lcv::slam {
namespace {

// Sum of rho(|e|^2) (Huber on the tangent error norm, or plain squares) at a pose, over the
// usable correspondences; also returns how many were usable (in front of the camera).
double PoseCost(const Eigen::Vector3d* bearings, const Eigen::Vector3d* points,
                const std::vector<int>* indices, int count, double huber, const Rigid3d& pose,
                int* used) {
  double cost = 0.0;
  *used = 0;
  for (int k = 0; k < count; ++k) {
    const int i = indices ? (*indices)[k] : k;
    const Eigen::Vector3d p = pose * points[i];
    if (bearings[i].dot(p) <= 0.0) continue;
    const double e2 = TangentError(TangentBasis(bearings[i]), p).squaredNorm();
    if (huber > 0.0 && e2 > huber * huber) {
      cost += 2.0 * huber * std::sqrt(e2) - huber * huber;
    } else {
      cost += e2;
    }
    ++*used;
  }
  return cost;
}

}  // namespace

int RefineAbsolutePose(const Eigen::Vector3d* bearings, const Eigen::Vector3d* points_in_world,
                       int count_all, const std::vector<int>* indices,
                       const PoseRefinementOptions& options, Rigid3d* cam_from_world,
                       double* final_cost) {
  const int count = indices ? static_cast<int>(indices->size()) : count_all;
  const double huber = options.huber_threshold_rad;
  Rigid3d pose = *cam_from_world;
  int used = 0;
  double cost = PoseCost(bearings, points_in_world, indices, count, huber, pose, &used);
  if (used < 3) return -1;

  int iteration = 0;
  for (; iteration < options.max_iterations; ++iteration) {
    Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
    Vector6d g = Vector6d::Zero();
    for (int k = 0; k < count; ++k) {
      const int i = indices ? (*indices)[k] : k;
      const Eigen::Vector3d p = pose * points_in_world[i];
      if (bearings[i].dot(p) <= 0.0) continue;
      const Eigen::Matrix<double, 3, 2> basis = TangentBasis(bearings[i]);
      const double norm = p.norm();
      const Eigen::Vector3d u = p / norm;
      const Eigen::Vector2d e = basis.transpose() * u;
      // d(u)/d(p) = (I - u u^T) / |p|; d(p)/d(delta) = [I, -[p]x] for the left perturbation.
      const Eigen::Matrix<double, 2, 3> J_e_p =
          basis.transpose() * (Eigen::Matrix3d::Identity() - u * u.transpose()) / norm;
      Eigen::Matrix<double, 2, 6> J;
      J.leftCols<3>() = J_e_p;
      J.rightCols<3>() = -J_e_p * SkewSymmetric(p);
      double weight = 1.0;
      if (huber > 0.0) {
        const double e_norm = e.norm();
        if (e_norm > huber) weight = huber / e_norm;
      }
      H.noalias() += weight * J.transpose() * J;
      g.noalias() += weight * J.transpose() * e;
    }
    const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(H);
    if (ldlt.info() != Eigen::Success) break;
    Vector6d step = -ldlt.solve(g);
    if (!step.allFinite()) break;
    // Step halving: accept the first step that does not raise the cost.
    bool accepted = false;
    for (int halving = 0; halving < 8; ++halving) {
      const Rigid3d candidate = Rigid3d::Exp(step) * pose;
      int candidate_used = 0;
      const double candidate_cost =
          PoseCost(bearings, points_in_world, indices, count, huber, candidate, &candidate_used);
      if (candidate_used >= 3 && candidate_cost <= cost) {
        pose = candidate;
        cost = candidate_cost;
        accepted = true;
        break;
      }
      step *= 0.5;
    }
    if (!accepted || step.norm() < options.min_step) {
      ++iteration;
      break;
    }
  }
  *cam_from_world = pose;
  if (final_cost) *final_cost = cost;
  return iteration;
}

void AbsolutePoseEstimator::Estimate(const std::vector<int>& sample,
                                     std::vector<Model>* models) const {
  const Eigen::Vector3d x[3] = {bearings_[sample[0]], bearings_[sample[1]], bearings_[sample[2]]};
  const Eigen::Vector3d X[3] = {points_[sample[0]], points_[sample[1]], points_[sample[2]]};
  SolveP3P(x, X, models);
}

void AbsolutePoseEstimator::Residuals(const Model& cam_from_world,
                                      std::vector<double>* squared_residuals) const {
  squared_residuals->resize(count_);
  const Eigen::Matrix3d R = cam_from_world.RotationMatrix();
  const Eigen::Vector3d& t = cam_from_world.translation;
  for (int i = 0; i < count_; ++i) {
    (*squared_residuals)[i] = SquaredChordError(bearings_[i], R * points_[i] + t);
  }
}

bool AbsolutePoseEstimator::Refine(const std::vector<int>& inliers, Model* cam_from_world) const {
  if (inliers.size() < 3) return false;
  PoseRefinementOptions options;
  options.max_iterations = 5;
  Rigid3d pose = *cam_from_world;
  if (RefineAbsolutePose(bearings_, points_, count_, &inliers, options, &pose) < 0) return false;
  *cam_from_world = pose;
  return true;
}

AbsolutePoseResult EstimateAbsolutePose(const std::vector<Eigen::Vector3d>& bearings,
                                        const std::vector<Eigen::Vector3d>& points_in_world,
                                        const AbsolutePoseOptions& options) {
  LCV_CHECK(bearings.size() == points_in_world.size())
      << bearings.size() << " bearings vs " << points_in_world.size() << " points";
  AbsolutePoseResult result;
  const int count = static_cast<int>(bearings.size());
  RansacOptions ransac = options.ransac;
  if (ransac.max_error <= 0.0) ransac.max_error = options.max_angular_error_rad;
  if (count < AbsolutePoseEstimator::kMinNumSamples) return result;

  const AbsolutePoseEstimator estimator(bearings.data(), points_in_world.data(), count);
  const RansacReport<Rigid3d> report = Ransac(ransac, estimator);
  result.num_trials = report.num_trials;
  if (!report.success) return result;
  result.cam_from_world = report.model;
  result.inlier_mask = report.inlier_mask;
  result.num_inliers = report.num_inliers;

  if (options.refine) {
    std::vector<int> inliers;
    inliers.reserve(report.num_inliers);
    for (int i = 0; i < count; ++i) {
      if (report.inlier_mask[i]) inliers.push_back(i);
    }
    Rigid3d refined = report.model;
    if (RefineAbsolutePose(bearings.data(), points_in_world.data(), count, &inliers, options.refinement,
                           &refined) >= 0) {
      // Re-classify with the refined pose (same chord threshold as RANSAC).
      std::vector<double> residuals;
      estimator.Residuals(refined, &residuals);
      const double threshold_sq = ransac.max_error * ransac.max_error;
      int refined_inliers = 0;
      std::vector<char> mask(count, 0);
      for (int i = 0; i < count; ++i) {
        mask[i] = residuals[i] <= threshold_sq;
        refined_inliers += mask[i];
      }
      if (refined_inliers >= report.num_inliers) {
        result.cam_from_world = refined;
        result.inlier_mask = std::move(mask);
        result.num_inliers = refined_inliers;
      }
    }
  }
  result.success = result.num_inliers >= options.min_num_inliers;
  return result;
}

}  // namespace lcv::slam
