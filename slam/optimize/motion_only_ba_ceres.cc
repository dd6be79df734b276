// The Ceres twin of MotionOnlyBA (slam/optimize/motion_only_ba.h): same residuals, kernel,
// rounds and classification, solved by Ceres to convergence. A reference for tests and
// benchmarks, not for the per-frame path.
#include <cmath>
#include <memory>

#include "slam/optimize/ceres_costs.h"
#include "slam/optimize/motion_only_ba.h"
#include "slam/optimize/residuals.h"
#include "slam/util/error.h"

namespace lcv::slam {

MotionOnlyBAReport SolveMotionOnlyBACeres(const MotionOnlyBAOptions& options,
                                          const Camera& camera, Rigid3d* cam_from_world,
                                          std::vector<MotionOnlyPointTerm>* points,
                                          std::vector<MotionOnlyLineTerm>* lines) {
  const std::string problem_text = options.Problem();
  LCV_CHECK(problem_text.empty()) << problem_text;
  LCV_CHECK(cam_from_world != nullptr && points != nullptr && lines != nullptr);
  const size_t num_lines = lines->size();
  std::vector<Eigen::Matrix3d> line_jacobians(num_lines);
  for (size_t i = 0; i < num_lines; ++i) {
    const Line3d& line = (*lines)[i].line;
    line_jacobians[i] =
        (*lines)[i].sqrt_information *
        (Eigen::Matrix3d::Identity() - line.direction * line.direction.transpose());
  }
  auto total_cost = [&]() {
    double cost = 0.0;
    for (const auto& term : *points) cost += term.inlier ? 0.5 * term.chi2 : 0.0;
    for (const auto& term : *lines) cost += term.inlier ? 0.5 * term.chi2 : 0.0;
    return cost;
  };

  MotionOnlyBAReport report;
  for (auto& term : *points) {
    term.chi2 = internal::PointTermChi2(camera, *cam_from_world, term);
    if (!std::isfinite(term.chi2)) term.inlier = false;
  }
  for (size_t i = 0; i < num_lines; ++i) {
    auto& term = (*lines)[i];
    term.chi2 = internal::LineTermChi2(camera, *cam_from_world, term, line_jacobians[i],
                                       options.line_weight);
    if (!std::isfinite(term.chi2)) term.inlier = false;
  }
  report.initial_cost = total_cost();

  double pose_params[internal::kPoseSize];
  std::vector<Eigen::Vector3d> restored(num_lines);
  bool solved_last_round = false;
  for (int round = 0; round < options.num_rounds; ++round) {
    const bool robust = round < options.robust_rounds;
    internal::PoseToParameters(*cam_from_world, pose_params);
    ceres::Problem::Options problem_options;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    internal::PoseManifold pose_manifold;
    ceres::Problem problem(problem_options);
    problem.AddParameterBlock(pose_params, internal::kPoseSize, &pose_manifold);
    int num_residual_blocks = 0;
    for (const auto& term : *points) {
      if (!term.inlier) continue;
      ceres::LossFunction* loss =
          robust ? new ceres::HuberLoss(std::sqrt(options.point_chi2_threshold)) : nullptr;
      // The point is constant: give Ceres a copy to hold it.
      problem.AddResidualBlock(
          new internal::ReprojectionCost(&camera, term.observed_px, term.information), loss,
          pose_params, const_cast<double*>(term.p_in_world.data()));
      problem.SetParameterBlockConstant(const_cast<double*>(term.p_in_world.data()));
      ++num_residual_blocks;
    }
    for (size_t i = 0; i < num_lines; ++i) {
      const auto& term = (*lines)[i];
      restored[i] = term.restored_point;
      if (!term.inlier) continue;
      ceres::LossFunction* loss =
          robust ? new ceres::HuberLoss(std::sqrt(options.line_chi2_threshold)) : nullptr;
      problem.AddResidualBlock(
          new internal::LineObservationCost(&camera, term.observed_px, term.information,
                                            term.line, term.sqrt_information,
                                            options.line_weight),
          loss, pose_params, restored[i].data());
      ++num_residual_blocks;
    }
    if (num_residual_blocks == 0) {
      solved_last_round = false;
      break;
    }
    ceres::Solver::Options solver_options;
    solver_options.linear_solver_type = ceres::DENSE_SCHUR;
    solver_options.max_num_iterations = 100;
    solver_options.function_tolerance = 1e-14;
    solver_options.gradient_tolerance = 1e-14;
    solver_options.parameter_tolerance = 1e-14;
    solver_options.num_threads = 1;
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
    report.num_iterations += static_cast<int>(summary.iterations.size());
    solved_last_round = summary.IsSolutionUsable();
    *cam_from_world = internal::PoseFromParameters(pose_params);
    for (size_t i = 0; i < num_lines; ++i) {
      if ((*lines)[i].inlier) (*lines)[i].restored_point = restored[i];
    }

    int num_inliers = 0;
    for (auto& term : *points) {
      term.chi2 = internal::PointTermChi2(camera, *cam_from_world, term);
      term.inlier = term.chi2 <= options.point_chi2_threshold;
      num_inliers += term.inlier;
    }
    for (size_t i = 0; i < num_lines; ++i) {
      auto& term = (*lines)[i];
      if (!term.inlier) {
        internal::RefitRestoredPoint(camera, *cam_from_world, line_jacobians[i],
                                     options.line_weight, &term);
      }
      term.chi2 = internal::LineTermChi2(camera, *cam_from_world, term, line_jacobians[i],
                                         options.line_weight);
      term.inlier = term.chi2 <= options.line_chi2_threshold;
      num_inliers += term.inlier;
    }
    if (num_inliers == 0) {
      solved_last_round = false;
      break;
    }
  }
  for (const auto& term : *points) report.num_point_inliers += term.inlier;
  for (const auto& term : *lines) report.num_line_inliers += term.inlier;
  report.final_cost = total_cost();
  report.success = solved_last_round;
  return report;
}

}  // namespace lcv::slam
