#include "slam/optimize/bundle_adjustment.h"

#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>

#include "slam/optimize/ceres_costs.h"
#include "slam/optimize/residuals.h"
#include "slam/util/error.h"

namespace lcv::slam {
namespace {

// BundleScaleAnchor's sigma as a share of the anchored distance: stiff, since the data has no
// say along the direction it removes (the term starts at zero and only stops the drift).
constexpr double kScaleAnchorSigma = 1e-3;

bool Finite(const Rigid3d& pose) {
  return pose.rotation.coeffs().allFinite() && pose.translation.allFinite() &&
         std::abs(pose.rotation.norm() - 1.0) < 1e-6;
}

// The parameter blocks of one BundleProblem, laid out for Ceres.
//
// Poses share one array (keyframes, then server keyframes), and points, lines and restored
// points X' another: points, then per line its parameters followed by its X' (kLineWithPointSize
// doubles each; copied back into the problem after each pass, CopyPointsBack). A free line with
// an observed X' is one parameter block of both (LineWithPointManifold): the two share the e_pL
// terms, and only as one block can the Schur complement eliminate them together, leaving the
// poses alone in the reduced system as for a point map (RunPass). With free lines the solver gets
// an explicit elimination ordering, and Ceres keeps the blocks of an ordering group in a
// std::set<double*>: in address order. Blocks spread over several arrays would be ordered by
// where the heap placed them, which changes the order of the Schur complement's sums and the
// result in its last digits from run to run (seen as LC-VSLAM client trajectories that differed
// in the 15th digit until ASLR was disabled). One array per group keeps the order the indices
// give.
struct Blocks {
  std::vector<double> reduced;     // poses
  std::vector<double> eliminated;  // points (3 each), then lines with their X'
  std::vector<Eigen::Matrix3d> sqrt_line_information;
  size_t server_offset = 0;  // in reduced: the first server keyframe's parameters
  size_t line_offset = 0;    // in eliminated: the first line's parameters
  size_t num_points = 0;

  double* Keyframe(size_t i) { return &reduced[internal::kPoseSize * i]; }
  double* ServerKeyframe(size_t i) { return &reduced[server_offset + internal::kPoseSize * i]; }
  double* Line(size_t i) { return &eliminated[line_offset + internal::kLineWithPointSize * i]; }
  const double* Keyframe(size_t i) const { return &reduced[internal::kPoseSize * i]; }
  const double* ServerKeyframe(size_t i) const {
    return &reduced[server_offset + internal::kPoseSize * i];
  }
  const double* Line(size_t i) const {
    return &eliminated[line_offset + internal::kLineWithPointSize * i];
  }
  double* Point(size_t i) { return &eliminated[3 * i]; }
  const double* Point(size_t i) const { return &eliminated[3 * i]; }
  double* Restored(size_t line) { return Line(line) + internal::kLineSize; }
  const double* Restored(size_t line) const { return Line(line) + internal::kLineSize; }
};

Blocks MakeBlocks(const BundleProblem& problem) {
  Blocks blocks;
  blocks.server_offset = internal::kPoseSize * problem.keyframes.size();
  blocks.reduced.resize(blocks.server_offset +
                        internal::kPoseSize * problem.server_keyframes.size());
  for (size_t i = 0; i < problem.keyframes.size(); ++i) {
    internal::PoseToParameters(problem.keyframes[i].cam_from_world, blocks.Keyframe(i));
  }
  for (size_t i = 0; i < problem.server_keyframes.size(); ++i) {
    internal::PoseToParameters(problem.server_keyframes[i].cam_from_world,
                               blocks.ServerKeyframe(i));
  }
  blocks.num_points = problem.points.size();
  blocks.line_offset = 3 * problem.points.size();
  blocks.eliminated.resize(blocks.line_offset +
                           internal::kLineWithPointSize * problem.lines.size());
  for (size_t i = 0; i < problem.points.size(); ++i) {
    Eigen::Map<Eigen::Vector3d>(blocks.Point(i)) = problem.points[i].position;
  }
  blocks.sqrt_line_information.resize(problem.lines.size());
  for (size_t i = 0; i < problem.lines.size(); ++i) {
    internal::LineToParameters(problem.lines[i].line, blocks.Line(i));
    Eigen::Map<Eigen::Vector3d>(blocks.Restored(i)) = problem.lines[i].restored_point;
    blocks.sqrt_line_information[i] = SqrtInformation(problem.lines[i].information);
  }
  return blocks;
}

// The points and X' of the blocks into the problem (after every pass: the outlier test reads
// the problem).
void CopyPointsBack(const Blocks& blocks, BundleProblem* problem) {
  for (size_t i = 0; i < problem->points.size(); ++i) {
    problem->points[i].position = Eigen::Map<const Eigen::Vector3d>(blocks.Point(i));
  }
  for (size_t i = 0; i < problem->lines.size(); ++i) {
    problem->lines[i].restored_point = Eigen::Map<const Eigen::Vector3d>(blocks.Restored(i));
  }
}

// Whitened squared residual of an observation at the current blocks (no kernel); infinity when
// the point cannot be projected.
double ObservationChi2(const BundleOptions& options, const BundleProblem& problem,
                       const Blocks& blocks, const BundleObservation& obs) {
  const BundleKeyframe& keyframe = problem.keyframes[obs.keyframe];
  const Rigid3d pose = internal::PoseFromParameters(blocks.Keyframe(obs.keyframe));
  Eigen::Vector2d r;
  if (!obs.on_line) {
    if (!ReprojectionResidual(*keyframe.camera, pose, problem.points[obs.landmark].position,
                              obs.observed_px, &r)) {
      return std::numeric_limits<double>::infinity();
    }
    return obs.information * r.squaredNorm();
  }
  const BundleLine& line = problem.lines[obs.landmark];
  if (!ReprojectionResidual(*keyframe.camera, pose, line.restored_point, obs.observed_px, &r)) {
    return std::numeric_limits<double>::infinity();
  }
  Eigen::Vector3d r_line;
  PointToLineResidual(line.restored_point,
                      internal::LineFromParameters(blocks.Line(obs.landmark)),
                      blocks.sqrt_line_information[obs.landmark], &r_line);
  return obs.information * r.squaredNorm() + options.line_weight * r_line.squaredNorm();
}

ceres::LinearSolverType SparseSchurSolver() {
  if (ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE) ||
      ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::EIGEN_SPARSE)) {
    return ceres::SPARSE_SCHUR;
  }
  return ceres::DENSE_SCHUR;
}

// Ends a Ceres solve, keeping its best state, once BundleOptions::should_stop says so.
class StopWhenAsked : public ceres::IterationCallback {
 public:
  explicit StopWhenAsked(const std::function<bool()>& should_stop) : should_stop_(should_stop) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    if (!should_stop_()) return ceres::SOLVER_CONTINUE;
    stopped_ = true;
    return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
  }
  bool stopped() const { return stopped_; }

 private:
  const std::function<bool()>& should_stop_;
  bool stopped_ = false;
};

// One Ceres pass over the observations not flagged outlier. Returns the summary; *stopped_early
// (when given) says whether options.should_stop ended it.
ceres::Solver::Summary RunPass(const BundleOptions& options, bool robust, int max_iterations,
                               BundleProblem* problem, Blocks* blocks,
                               bool* stopped_early = nullptr) {
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem ceres_problem(problem_options);
  internal::PoseManifold pose_manifold;
  internal::LineManifold line_manifold;
  internal::LineWithPointManifold line_with_point_manifold;

  std::vector<char> keyframe_used(problem->keyframes.size(), 0);
  std::vector<char> server_used(problem->server_keyframes.size(), 0);
  std::vector<char> point_used(problem->points.size(), 0);
  std::vector<char> line_used(problem->lines.size(), 0);
  auto add_keyframe = [&](int i) {
    if (keyframe_used[i]) return;
    keyframe_used[i] = 1;
    ceres_problem.AddParameterBlock(blocks->Keyframe(i), internal::kPoseSize,
                                    &pose_manifold);
    if (problem->keyframes[i].fixed) {
      ceres_problem.SetParameterBlockConstant(blocks->Keyframe(i));
    }
  };
  // A free line whose X' is observed in this pass is one block with its X' (see Blocks).
  std::vector<char> line_with_point(problem->lines.size(), 0);
  for (const BundleObservation& obs : problem->observations) {
    if (!obs.outlier && obs.on_line && !problem->lines[obs.landmark].fixed) {
      line_with_point[obs.landmark] = 1;
    }
  }
  auto add_line = [&](int i) {
    if (line_used[i]) return;
    line_used[i] = 1;
    if (line_with_point[i]) {
      ceres_problem.AddParameterBlock(blocks->Line(i), internal::kLineWithPointSize,
                                      &line_with_point_manifold);
      return;
    }
    ceres_problem.AddParameterBlock(blocks->Line(i), internal::kLineSize,
                                    &line_manifold);
    if (problem->lines[i].fixed) ceres_problem.SetParameterBlockConstant(blocks->Line(i));
  };
  using Part = internal::SubBlockCost::Part;

  const double point_delta = std::sqrt(options.point_chi2_threshold);
  const double line_delta = std::sqrt(options.line_chi2_threshold);
  for (const BundleObservation& obs : problem->observations) {
    if (obs.outlier) continue;
    const BundleKeyframe& keyframe = problem->keyframes[obs.keyframe];
    add_keyframe(obs.keyframe);
    double* pose = blocks->Keyframe(obs.keyframe);
    if (!obs.on_line) {
      BundlePoint& point = problem->points[obs.landmark];
      ceres_problem.AddResidualBlock(
          new internal::ReprojectionCost(keyframe.camera, obs.observed_px, obs.information),
          robust ? new ceres::HuberLoss(point_delta) : nullptr, pose,
          blocks->Point(obs.landmark));
      if (!point_used[obs.landmark]) {
        point_used[obs.landmark] = 1;
        if (point.fixed) ceres_problem.SetParameterBlockConstant(blocks->Point(obs.landmark));
      }
      continue;
    }
    BundleLine& line = problem->lines[obs.landmark];
    ceres::LossFunction* loss = robust ? new ceres::HuberLoss(line_delta) : nullptr;
    if (line.fixed) {
      ceres_problem.AddResidualBlock(
          new internal::LineObservationCost(keyframe.camera, obs.observed_px, obs.information,
                                            line.line, blocks->sqrt_line_information[obs.landmark],
                                            options.line_weight),
          loss, pose, blocks->Restored(obs.landmark));
    } else {
      add_line(obs.landmark);
      // Blocks of the cost: pose, X', line; here pose and [line, X'].
      ceres_problem.AddResidualBlock(
          new internal::SubBlockCost(
              std::make_unique<internal::FreeLineObservationCost>(
                  keyframe.camera, obs.observed_px, obs.information,
                  blocks->sqrt_line_information[obs.landmark], options.line_weight),
              {internal::kPoseSize, internal::kLineWithPointSize},
              {Part{0, 0}, Part{1, internal::kLineSize}, Part{1, 0}}),
          loss, pose, blocks->Line(obs.landmark));
    }
  }
  for (const BundleVirtualObservation& v : problem->virtual_observations) {
    const int s = v.server_keyframe;
    if (!server_used[s]) {
      server_used[s] = 1;
      ceres_problem.AddParameterBlock(blocks->ServerKeyframe(s), internal::kPoseSize,
                                      &pose_manifold);
      if (problem->server_keyframes[s].fixed) {
        ceres_problem.SetParameterBlockConstant(blocks->ServerKeyframe(s));
      }
    }
    add_line(v.line);
    const Eigen::Matrix2d sqrt_information =
        v.sqrt_information.isZero(0.0)
            ? Eigen::Matrix2d(Eigen::Matrix2d::Identity() / options.virtual_sigma_rad)
            : v.sqrt_information;
    ceres::CostFunction* cost =
        new internal::VirtualObservationCost(v.observed_normal, sqrt_information);
    if (line_with_point[v.line]) {
      cost = new internal::SubBlockCost(std::unique_ptr<ceres::CostFunction>(cost),
                                        {internal::kPoseSize, internal::kLineWithPointSize},
                                        {Part{0, 0}, Part{1, 0}});
    }
    ceres_problem.AddResidualBlock(
        cost,
        options.virtual_huber_delta > 0.0 ? new ceres::HuberLoss(options.virtual_huber_delta)
                                          : nullptr,
        blocks->ServerKeyframe(s), blocks->Line(v.line));
  }

  const BundleScaleAnchor& anchor = problem->scale_anchor;
  if (anchor.keyframe >= 0 && keyframe_used[anchor.keyframe]) {
    ceres_problem.AddResidualBlock(
        new internal::CentreDistanceCost(
            problem->keyframes[anchor.fixed_keyframe].cam_from_world.Center(), anchor.distance,
            1.0 / (kScaleAnchorSigma * anchor.distance)),
        nullptr, blocks->Keyframe(anchor.keyframe));
  }

  ceres::Solver::Summary summary;
  if (ceres_problem.NumResidualBlocks() == 0) {
    summary.termination_type = ceres::CONVERGENCE;
    summary.message = "nothing to optimize";
    return summary;
  }
  ceres::Solver::Options solver_options;
  // The reduced camera system is dense for a local window (every keyframe sees most points):
  // dense Cholesky wins up to a few hundred pose blocks (Ceres' own guidance), sparse beyond.
  int num_pose_blocks = 0;
  for (const char used : keyframe_used) num_pose_blocks += used;
  for (const char used : server_used) num_pose_blocks += used;
  // Free lines share e_pL terms with their X', so as two blocks both could not be eliminated:
  // Ceres' automatic ordering put the lines in the eliminated set and their X' in a dense
  // reduced system (measured 30 s for 12 keyframes and ~1000 lines), and an explicit ordering
  // with the lines beside the poses left a large sparse reduced system whose assembly and
  // factorization made the line client's local BA 2-2.5x the point client's. As one block
  // (Blocks) a line and its X' touch only poses, like a point: points, lines and X' are
  // eliminated (group 0), the poses alone are the reduced system (group 1). A free line without
  // an observed X' touches only server keyframes and is eliminated too.
  int num_free_lines = 0;
  for (size_t i = 0; i < line_used.size(); ++i) {
    num_free_lines += line_used[i] && !problem->lines[i].fixed;
  }
  if (num_free_lines > 0) {
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    for (size_t i = 0; i < problem->points.size(); ++i) {
      if (point_used[i]) ordering->AddElementToGroup(blocks->Point(i), 0);
    }
    for (size_t i = 0; i < problem->lines.size(); ++i) {
      if (line_used[i] && !problem->lines[i].fixed) {
        ordering->AddElementToGroup(blocks->Line(i), 0);
      } else if (line_used[i]) {
        ordering->AddElementToGroup(blocks->Line(i), 1);  // constant
      }
      double* restored = blocks->Restored(i);
      if (!line_with_point[i] && ceres_problem.HasParameterBlock(restored)) {
        ordering->AddElementToGroup(restored, 0);
      }
    }
    for (size_t i = 0; i < keyframe_used.size(); ++i) {
      if (keyframe_used[i]) ordering->AddElementToGroup(blocks->Keyframe(i), 1);
    }
    for (size_t i = 0; i < server_used.size(); ++i) {
      if (server_used[i]) ordering->AddElementToGroup(blocks->ServerKeyframe(i), 1);
    }
    solver_options.linear_solver_ordering = ordering;
  }
  solver_options.linear_solver_type =
      num_pose_blocks <= 100 ? ceres::DENSE_SCHUR : SparseSchurSolver();
  solver_options.max_num_iterations = max_iterations;
  solver_options.num_threads = options.num_threads;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.logging_type = ceres::SILENT;
  std::optional<StopWhenAsked> stop;
  if (options.should_stop) {
    stop.emplace(options.should_stop);
    solver_options.callbacks.push_back(&*stop);
  }
  ceres::Solve(solver_options, &ceres_problem, &summary);
  if (stopped_early != nullptr) *stopped_early = stop && stop->stopped();
  return summary;
}

}  // namespace

std::string BundleProblem::Problem() const {
  std::ostringstream out;
  const int num_keyframes = static_cast<int>(keyframes.size());
  const int num_servers = static_cast<int>(server_keyframes.size());
  const int num_points = static_cast<int>(points.size());
  const int num_lines = static_cast<int>(lines.size());
  for (size_t i = 0; i < keyframes.size(); ++i) {
    if (keyframes[i].camera == nullptr) {
      out << "keyframes[" << i << "]: no camera";
      return out.str();
    }
    if (!Finite(keyframes[i].cam_from_world)) {
      out << "keyframes[" << i << "]: pose not finite or rotation not unit";
      return out.str();
    }
  }
  for (size_t i = 0; i < server_keyframes.size(); ++i) {
    if (!Finite(server_keyframes[i].cam_from_world)) {
      out << "server_keyframes[" << i << "]: pose not finite or rotation not unit";
      return out.str();
    }
  }
  for (size_t i = 0; i < points.size(); ++i) {
    if (!points[i].position.allFinite()) {
      out << "points[" << i << "]: position not finite";
      return out.str();
    }
  }
  for (size_t i = 0; i < lines.size(); ++i) {
    const BundleLine& line = lines[i];
    if (!line.line.anchor.allFinite() || !line.restored_point.allFinite() ||
        !line.information.allFinite()) {
      out << "lines[" << i << "]: not finite";
      return out.str();
    }
    if (std::abs(line.line.direction.norm() - 1.0) > 1e-6) {
      out << "lines[" << i << "]: direction norm " << line.line.direction.norm();
      return out.str();
    }
  }
  for (size_t i = 0; i < observations.size(); ++i) {
    const BundleObservation& obs = observations[i];
    if (obs.keyframe < 0 || obs.keyframe >= num_keyframes) {
      out << "observations[" << i << "]: keyframe " << obs.keyframe << " out of range";
      return out.str();
    }
    const int limit = obs.on_line ? num_lines : num_points;
    if (obs.landmark < 0 || obs.landmark >= limit) {
      out << "observations[" << i << "]: " << (obs.on_line ? "line " : "point ") << obs.landmark
          << " out of range";
      return out.str();
    }
    if (!(obs.information > 0.0) || !obs.observed_px.allFinite()) {
      out << "observations[" << i << "]: information must be > 0 and pixel finite";
      return out.str();
    }
  }
  for (size_t i = 0; i < virtual_observations.size(); ++i) {
    const BundleVirtualObservation& v = virtual_observations[i];
    if (v.server_keyframe < 0 || v.server_keyframe >= num_servers) {
      out << "virtual_observations[" << i << "]: server keyframe " << v.server_keyframe
          << " out of range";
      return out.str();
    }
    if (v.line < 0 || v.line >= num_lines) {
      out << "virtual_observations[" << i << "]: line " << v.line << " out of range";
      return out.str();
    }
    if (std::abs(v.observed_normal.norm() - 1.0) > 1e-6) {
      out << "virtual_observations[" << i << "]: normal norm " << v.observed_normal.norm();
      return out.str();
    }
  }
  return out.str();
}

std::string BundleOptions::Problem() const {
  std::ostringstream out;
  if (max_iterations < 1) out << "max_iterations must be >= 1";
  else if (max_refine_iterations < 0) out << "max_refine_iterations must be >= 0";
  else if (!(point_chi2_threshold > 0.0)) out << "point_chi2_threshold must be > 0";
  else if (!(line_chi2_threshold > 0.0)) out << "line_chi2_threshold must be > 0";
  else if (!(line_weight >= 0.0)) out << "line_weight must be >= 0";
  else if (!(virtual_sigma_rad > 0.0)) out << "virtual_sigma_rad must be > 0";
  else if (num_threads < 1) out << "num_threads must be >= 1";
  else if (!(function_tolerance >= 0.0)) out << "function_tolerance must be >= 0";
  return out.str();
}

void MakeVirtualObservations(const std::vector<std::pair<int, int>>& server_keyframe_line_pairs,
                             BundleProblem* problem) {
  std::vector<Rigid3d> seen_from;
  seen_from.reserve(problem->server_keyframes.size());
  for (const BundleServerKeyframe& s : problem->server_keyframes) {
    seen_from.push_back(s.cam_from_world);
  }
  std::vector<Line3d> seen_lines;
  seen_lines.reserve(problem->lines.size());
  for (const BundleLine& l : problem->lines) seen_lines.push_back(l.line);
  MakeVirtualObservations(server_keyframe_line_pairs, seen_from, seen_lines, problem);
}

void MakeVirtualObservations(const std::vector<std::pair<int, int>>& server_keyframe_line_pairs,
                             const std::vector<Rigid3d>& seen_from,
                             const std::vector<Line3d>& seen_lines, BundleProblem* problem) {
  LCV_CHECK(seen_from.size() == problem->server_keyframes.size() &&
            seen_lines.size() == problem->lines.size())
      << "seen_from / seen_lines must match the problem's server keyframes / lines";
  for (const auto& [server, line] : server_keyframe_line_pairs) {
    LCV_CHECK(server >= 0 && server < static_cast<int>(problem->server_keyframes.size()) &&
              line >= 0 && line < static_cast<int>(problem->lines.size()))
        << "pair (" << server << ", " << line << ") out of range";
    const Eigen::Vector3d normal = LinePlaneNormal(seen_from[server], seen_lines[line]);
    if (normal.isZero()) continue;
    problem->virtual_observations.push_back({server, line, normal});
  }
}

BundleScaleAnchor ChooseScaleAnchor(const BundleProblem& problem) {
  BundleScaleAnchor none;
  if (!problem.lines.empty() || !problem.server_keyframes.empty() ||
      !problem.virtual_observations.empty()) {
    return none;
  }
  std::vector<char> observed(problem.keyframes.size(), 0);
  for (const BundleObservation& obs : problem.observations) {
    if (obs.outlier) continue;
    if (problem.points[obs.landmark].fixed) return none;  // a fixed point carries the scale
    observed[obs.keyframe] = 1;
  }
  int fixed = -1;
  for (size_t i = 0; i < problem.keyframes.size(); ++i) {
    if (!observed[i] || !problem.keyframes[i].fixed) continue;
    if (fixed >= 0) return none;  // two fixed keyframes hold the scale
    fixed = static_cast<int>(i);
  }
  if (fixed < 0) return none;
  const Eigen::Vector3d fixed_centre = problem.keyframes[fixed].cam_from_world.Center();
  BundleScaleAnchor anchor;
  for (size_t i = 0; i < problem.keyframes.size(); ++i) {
    if (!observed[i] || problem.keyframes[i].fixed) continue;
    const double distance = (problem.keyframes[i].cam_from_world.Center() - fixed_centre).norm();
    if (distance > anchor.distance) {
      anchor = {fixed, static_cast<int>(i), distance};
    }
  }
  return anchor.distance > 0.0 ? anchor : none;
}

BundleReport SolveBundleAdjustment(const BundleOptions& options, BundleProblem* problem) {
  const auto start = std::chrono::steady_clock::now();
  LCV_CHECK(problem != nullptr);
  const std::string options_problem = options.Problem();
  LCV_CHECK(options_problem.empty()) << options_problem;
  const std::string problem_text = problem->Problem();
  LCV_CHECK(problem_text.empty()) << problem_text;

  problem->scale_anchor =
      options.hold_monocular_scale ? ChooseScaleAnchor(*problem) : BundleScaleAnchor();
  Blocks blocks = MakeBlocks(*problem);
  BundleReport report;
  ceres::Solver::Summary summary = RunPass(options, /*robust=*/true, options.max_iterations,
                                           problem, &blocks, &report.stopped_early);
  CopyPointsBack(blocks, problem);
  report.initial_cost = summary.initial_cost;
  report.num_iterations = static_cast<int>(summary.iterations.size());
  report.success = summary.IsSolutionUsable() || summary.message == "nothing to optimize";
  report.message = summary.message;

  auto classify = [&]() {
    int num_outliers = 0;
    for (BundleObservation& obs : problem->observations) {
      obs.chi2 = ObservationChi2(options, *problem, blocks, obs);
      const double threshold =
          obs.on_line ? options.line_chi2_threshold : options.point_chi2_threshold;
      obs.outlier = obs.outlier || !(obs.chi2 <= threshold);
      num_outliers += obs.outlier;
    }
    return num_outliers;
  };
  report.num_outliers = classify();
  if (options.refine_without_outliers && options.max_refine_iterations > 0 && report.success &&
      !report.stopped_early) {
    summary = RunPass(options, /*robust=*/false, options.max_refine_iterations, problem, &blocks,
                      &report.stopped_early);
    CopyPointsBack(blocks, problem);
    report.num_iterations += static_cast<int>(summary.iterations.size());
    report.success = summary.IsSolutionUsable() || summary.message == "nothing to optimize";
    report.message = summary.message;
    report.num_outliers = classify();
  }
  report.final_cost = summary.final_cost;

  for (size_t i = 0; i < problem->keyframes.size(); ++i) {
    problem->keyframes[i].cam_from_world =
        internal::PoseFromParameters(blocks.Keyframe(i));
  }
  for (size_t i = 0; i < problem->server_keyframes.size(); ++i) {
    problem->server_keyframes[i].cam_from_world =
        internal::PoseFromParameters(blocks.ServerKeyframe(i));
  }
  for (size_t i = 0; i < problem->lines.size(); ++i) {
    problem->lines[i].line = internal::LineFromParameters(blocks.Line(i));
  }
  report.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace lcv::slam
