#include "slam/optimize/rigid_stereo_ba.h"

#include <chrono>
#include <cmath>
#include <limits>

#include "slam/optimize/ceres_costs.h"
#include "slam/optimize/residuals.h"
#include "slam/util/error.h"

namespace lcv::slam {
namespace {

double ObservationChi2(const BundleOptions& options, const std::vector<RigidStereoView>& views,
                       double group_scale, const Rigid3d& reference_from_world,
                       const std::vector<RigidStereoLine>& lines,
                       const std::vector<Eigen::Matrix3d>& sqrt_information,
                       const RigidStereoObservation& obs) {
  const RigidStereoView& view = views[obs.view];
  const RigidStereoLine& line = lines[obs.line];
  Rigid3d cam_from_reference = view.cam_from_reference;
  cam_from_reference.translation *= group_scale;
  Eigen::Vector2d r;
  if (!ReprojectionResidual(*view.camera, cam_from_reference * reference_from_world,
                            line.restored_point, obs.observed_px, &r)) {
    return std::numeric_limits<double>::infinity();
  }
  if (line.fixed) return obs.information * r.squaredNorm();
  Eigen::Vector3d r_line;
  PointToLineResidual(line.restored_point, line.line, sqrt_information[obs.line], &r_line);
  return obs.information * r.squaredNorm() + options.line_weight * r_line.squaredNorm();
}

}  // namespace

BundleReport SolveRigidStereoBA(const BundleOptions& options,
                                const std::vector<RigidStereoView>& views,
                                Rigid3d* reference_cam_from_world,
                                std::vector<RigidStereoLine>* lines,
                                std::vector<RigidStereoObservation>* observations,
                                double* group_scale) {
  const auto start = std::chrono::steady_clock::now();
  const std::string options_problem = options.Problem();
  LCV_CHECK(options_problem.empty()) << options_problem;
  LCV_CHECK(reference_cam_from_world != nullptr && lines != nullptr && observations != nullptr);
  for (const RigidStereoView& view : views) LCV_CHECK(view.camera != nullptr);
  for (const RigidStereoObservation& obs : *observations) {
    LCV_CHECK(obs.view >= 0 && obs.view < static_cast<int>(views.size()) && obs.line >= 0 &&
              obs.line < static_cast<int>(lines->size()))
        << "observation (view " << obs.view << ", line " << obs.line << ") out of range";
  }
  std::vector<Eigen::Matrix3d> sqrt_information(lines->size());
  for (size_t i = 0; i < lines->size(); ++i) {
    sqrt_information[i] = SqrtInformation((*lines)[i].information);
  }
  double pose[internal::kPoseSize];
  internal::PoseToParameters(*reference_cam_from_world, pose);
  LCV_CHECK(group_scale == nullptr || *group_scale > 0.0) << "group scale must be > 0";
  double scale = group_scale != nullptr ? *group_scale : 1.0;

  auto run_pass = [&](bool robust, int max_iterations) {
    ceres::Problem::Options problem_options;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(problem_options);
    internal::PoseManifold pose_manifold;
    problem.AddParameterBlock(pose, internal::kPoseSize, &pose_manifold);
    for (const RigidStereoObservation& obs : *observations) {
      if (obs.outlier) continue;
      RigidStereoLine& line = (*lines)[obs.line];
      // A fixed X' keeps the e_pL cost with no line part (weight 0): the pixel term alone.
      const double line_weight = line.fixed ? 0.0 : options.line_weight;
      ceres::LossFunction* loss =
          robust ? new ceres::HuberLoss(std::sqrt(line.fixed ? options.point_chi2_threshold
                                                             : options.line_chi2_threshold))
                 : nullptr;
      const RigidStereoView& view = views[obs.view];
      if (group_scale != nullptr && view.cam_from_reference.translation.squaredNorm() > 0.0) {
        problem.AddResidualBlock(
            new internal::ScaledOffsetLineCost(view.camera, obs.observed_px, obs.information,
                                               line.line, sqrt_information[obs.line], line_weight,
                                               view.cam_from_reference),
            loss, pose, line.restored_point.data(), &scale);
      } else {
        problem.AddResidualBlock(
            new internal::LineObservationCost(view.camera, obs.observed_px, obs.information,
                                              line.line, sqrt_information[obs.line], line_weight,
                                              view.cam_from_reference),
            loss, pose, line.restored_point.data());
      }
      if (line.fixed) problem.SetParameterBlockConstant(line.restored_point.data());
    }
    if (problem.HasParameterBlock(&scale)) problem.SetParameterLowerBound(&scale, 0, 1e-6);
    ceres::Solver::Summary summary;
    if (problem.NumResidualBlocks() == 0) {
      summary.message = "no observations";
      return summary;
    }
    ceres::Solver::Options solver_options;
    solver_options.linear_solver_type = ceres::DENSE_SCHUR;
    solver_options.max_num_iterations = max_iterations;
    solver_options.num_threads = options.num_threads;
    solver_options.function_tolerance = options.function_tolerance;
    solver_options.logging_type = ceres::SILENT;
    ceres::Solve(solver_options, &problem, &summary);
    return summary;
  };
  auto classify = [&]() {
    const Rigid3d reference_from_world = internal::PoseFromParameters(pose);
    int num_outliers = 0;
    for (RigidStereoObservation& obs : *observations) {
      obs.chi2 = ObservationChi2(options, views, scale, reference_from_world, *lines,
                                 sqrt_information, obs);
      const double threshold =
          (*lines)[obs.line].fixed ? options.point_chi2_threshold : options.line_chi2_threshold;
      obs.outlier = obs.outlier || !(obs.chi2 <= threshold);
      num_outliers += obs.outlier;
    }
    return num_outliers;
  };

  BundleReport report;
  ceres::Solver::Summary summary = run_pass(true, options.max_iterations);
  report.initial_cost = summary.initial_cost;
  report.num_iterations = static_cast<int>(summary.iterations.size());
  report.success = summary.IsSolutionUsable();
  report.message = summary.message;
  report.num_outliers = classify();
  if (report.success && options.refine_without_outliers && options.max_refine_iterations > 0) {
    summary = run_pass(false, options.max_refine_iterations);
    report.num_iterations += static_cast<int>(summary.iterations.size());
    report.success = summary.IsSolutionUsable();
    report.message = summary.message;
    report.num_outliers = classify();
  }
  report.final_cost = summary.final_cost;
  if (report.success) {
    *reference_cam_from_world = internal::PoseFromParameters(pose);
    if (group_scale != nullptr) *group_scale = scale;
  }
  report.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace lcv::slam
