#include "mapping/merge_optimization.h"

#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <sstream>

#include <Eigen/Eigenvalues>

#include "slam/optimize/ceres_costs.h"
#include "slam/optimize/residuals.h"
#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

using slam::Id;
namespace si = slam::internal;

// Symmetric square root of a 2x2 SPD matrix.
// LineIntersectionResidual / sigma. Blocks: the moving line (6); the other line is constant.
class LineIntersectionCost : public ceres::SizedCostFunction<1, si::kLineSize> {
 public:
  LineIntersectionCost(const slam::Line3d& fixed, double sigma)
      : fixed_(fixed), inverse_sigma_(1.0 / sigma) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const slam::Line3d moving = si::LineFromParameters(parameters[0]);
    double r;
    Eigen::Matrix<double, 1, 4> J;
    if (!slam::LineIntersectionResidual(moving, fixed_, &r, jacobians ? &J : nullptr)) {
      return false;
    }
    residuals[0] = inverse_sigma_ * r;
    if (jacobians && jacobians[0]) {
      for (int i = 0; i < 4; ++i) jacobians[0][i] = inverse_sigma_ * J(i);
      jacobians[0][4] = jacobians[0][5] = 0.0;  // lifted convention (ceres_costs.h)
    }
    return true;
  }

 private:
  slam::Line3d fixed_;
  double inverse_sigma_;
};

}  // namespace

std::string MergeOptimizationOptions::Problem() const {
  std::ostringstream out;
  if (!(virtual_sigma_rad > 0.0)) out << "virtual_sigma_rad must be > 0";
  else if (!(huber_delta >= 0.0)) out << "huber_delta must be >= 0";
  else if (max_iterations < 1) out << "max_iterations must be >= 1";
  else if (num_threads < 1) out << "num_threads must be >= 1";
  return out.str();
}

double LinePerpendicularSigma(const Eigen::Matrix3d& information) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(information);
  const double largest = eig.eigenvalues()(2);
  for (int i = 0; i < 3; ++i) {
    const double v = eig.eigenvalues()(i);
    if (v > 1e-12 * largest && v > 0.0) return 1.0 / std::sqrt(v);
  }
  return std::numeric_limits<double>::infinity();
}

std::vector<VirtualObservationRecord> VirtualObservationsOf(const slam::Map& map) {
  std::vector<VirtualObservationRecord> records;
  for (const auto& [kf_id, kf] : map.server_keyframes) {
    for (const Id line_id : kf.line_ids) {
      const auto line = map.lines.find(line_id);
      if (line == map.lines.end()) continue;
      const Eigen::Vector3d n = slam::LinePlaneNormal(kf.cam_from_world, line->second.line);
      if (n.squaredNorm() > 0.5) records.push_back({kf_id, line_id, n, -1});
    }
  }
  return records;
}

MergeOptimizationReport OptimizeLineCloud(const MergeOptimizationOptions& options,
                                          const std::vector<VirtualObservationRecord>& records,
                                          const std::vector<ObservedLineCopy>& copies,
                                          const std::set<Id>& fixed_server_keyframes,
                                          const std::set<Id>& fixed_lines, slam::Map* map) {
  const std::string problem_text = options.Problem();
  LCV_CHECK(problem_text.empty()) << problem_text;
  const auto start = std::chrono::steady_clock::now();
  MergeOptimizationReport report;

  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  si::PoseManifold pose_manifold;
  si::LineManifold line_manifold;
  std::map<Id, std::array<double, si::kPoseSize>> poses;
  std::map<Id, std::array<double, si::kLineSize>> lines;
  std::map<int, std::array<double, si::kLineSize>> copy_blocks;

  auto pose_block = [&](Id id) {
    auto it = poses.find(id);
    if (it != poses.end()) return it->second.data();
    double* block = poses[id].data();
    si::PoseToParameters(map->server_keyframes.at(id).cam_from_world, block);
    problem.AddParameterBlock(block, si::kPoseSize, &pose_manifold);
    if (fixed_server_keyframes.count(id)) {
      problem.SetParameterBlockConstant(block);
    } else {
      ++report.num_server_keyframes;
    }
    return block;
  };
  auto line_block = [&](Id id) {
    auto it = lines.find(id);
    if (it != lines.end()) return it->second.data();
    double* block = lines[id].data();
    si::LineToParameters(map->lines.at(id).line, block);
    problem.AddParameterBlock(block, si::kLineSize, &line_manifold);
    if (fixed_lines.count(id)) {
      problem.SetParameterBlockConstant(block);
    } else {
      ++report.num_lines;
    }
    return block;
  };
  auto copy_block = [&](int index) {
    auto it = copy_blocks.find(index);
    if (it != copy_blocks.end()) return it->second.data();
    const ObservedLineCopy& copy = copies[index];
    double* block = copy_blocks[index].data();
    si::LineToParameters(copy.line, block);
    problem.AddParameterBlock(block, si::kLineSize, &line_manifold);
    // Tied to the line it was merged into: they meet at the hidden point.
    const slam::LineLandmark& target = map->lines.at(copy.line_id);
    double sigma = std::hypot(LinePerpendicularSigma(copy.information),
                              LinePerpendicularSigma(target.information));
    if (!std::isfinite(sigma) || !(sigma > 0.0)) sigma = 1.0;
    // The kept line enters as a constant of this term: a base line (fixed anyway), or for a
    // duplicate of two uploads' lines, the kept one held by its own observations.
    problem.AddResidualBlock(new LineIntersectionCost(target.line, sigma), nullptr, block);
    ++report.num_copies;
    return block;
  };

  for (const VirtualObservationRecord& r : records) {
    if (!map->server_keyframes.count(r.server_keyframe_id) || !map->lines.count(r.line_id)) {
      continue;
    }
    const bool on_copy = r.copy >= 0 && r.copy < static_cast<int>(copies.size());
    if (!on_copy && fixed_server_keyframes.count(r.server_keyframe_id) &&
        fixed_lines.count(r.line_id)) {
      continue;  // a constant term
    }
    double* pose = pose_block(r.server_keyframe_id);
    double* line = on_copy ? copy_block(r.copy) : line_block(r.line_id);
    const slam::Line3d line_now = si::LineFromParameters(line);
    const Eigen::Matrix3d& information =
        on_copy ? copies[r.copy].information : map->lines.at(r.line_id).information;
    Eigen::Matrix2d sqrt_information =
        Eigen::Matrix2d::Identity() / options.virtual_sigma_rad;
    if (options.propagate_information) {
      sqrt_information = slam::VirtualObservationSqrtInformation(
          map->server_keyframes.at(r.server_keyframe_id).cam_from_world, line_now, r.normal,
          information, options.virtual_sigma_rad);
    }
    problem.AddResidualBlock(
        new si::VirtualObservationCost(r.normal, sqrt_information),
        options.huber_delta > 0.0 ? new ceres::HuberLoss(options.huber_delta) : nullptr, pose,
        line);
    ++report.num_virtual_observations;
  }

  ceres::Solver::Summary summary;
  if (problem.NumResidualBlocks() > 0) {
    ceres::Solver::Options solver;
    const bool sparse =
        ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE) ||
        ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::EIGEN_SPARSE);
    solver.linear_solver_type =
        poses.size() <= 100 || !sparse ? ceres::DENSE_SCHUR : ceres::SPARSE_SCHUR;
    solver.max_num_iterations = options.max_iterations;
    solver.num_threads = options.num_threads;
    solver.logging_type = ceres::SILENT;
    ceres::Solve(solver, &problem, &summary);
    report.success = summary.IsSolutionUsable();
    report.num_iterations = static_cast<int>(summary.iterations.size());
    report.cost_before = summary.initial_cost;
    report.cost_after = summary.final_cost;
    report.message = summary.message;
  } else {
    report.success = true;
    report.message = "nothing to optimize";
  }
  if (report.success) {
    for (const auto& [id, block] : poses) {
      if (!fixed_server_keyframes.count(id)) {
        map->server_keyframes.at(id).cam_from_world = si::PoseFromParameters(block.data());
      }
    }
    for (const auto& [id, block] : lines) {
      if (fixed_lines.count(id)) continue;
      slam::LineLandmark& landmark = map->lines.at(id);
      const slam::Line3d moved = si::LineFromParameters(block.data());
      // Omega_L turns with the direction (smallest rotation old -> new), so that the direction
      // stays in its null space (map invariant).
      landmark.information =
          slam::TurnLineInformation(landmark.information, landmark.line.direction,
                                    moved.direction);
      landmark.line = moved;
      landmark.line.direction.normalize();
    }
  }
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace lcv::mapping
