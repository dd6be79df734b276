#include "slam/optimize/pose_graph.h"

#include <chrono>
#include <cmath>
#include <sstream>

#include <ceres/ceres.h>
#include <ceres/product_manifold.h>

#include <Eigen/Cholesky>

#include "slam/util/error.h"

namespace lcv::slam {
namespace {

// Vertex parameters: [qx qy qz qw tx ty tz log_scale].
constexpr int kVertexSize = 8;

void VertexToParameters(const Sim3d& sim, double* params) {
  const Eigen::Quaterniond q = sim.rotation.normalized();
  params[0] = q.x();
  params[1] = q.y();
  params[2] = q.z();
  params[3] = q.w();
  params[4] = sim.translation.x();
  params[5] = sim.translation.y();
  params[6] = sim.translation.z();
  params[7] = std::log(sim.scale);
}

Sim3d VertexFromParameters(const double* params) {
  Eigen::Quaterniond q(params[3], params[0], params[1], params[2]);
  q.normalize();
  return Sim3d(std::exp(params[7]), q, Eigen::Vector3d(params[4], params[5], params[6]));
}

// [t; 2 q.vec; log s] of E = measured * from * to^-1, for any scalar type.
template <typename T>
void RelativeError(const Eigen::Quaternion<T>& q_measured, const Eigen::Matrix<T, 3, 1>& t_measured,
                   const T& log_s_measured, const T* from, const T* to, T* residual) {
  const Eigen::Quaternion<T> q_from(from[3], from[0], from[1], from[2]);
  const Eigen::Matrix<T, 3, 1> t_from(from[4], from[5], from[6]);
  const Eigen::Quaternion<T> q_to(to[3], to[0], to[1], to[2]);
  const Eigen::Matrix<T, 3, 1> t_to(to[4], to[5], to[6]);
  const T s_measured = exp(log_s_measured);
  const T s_from = exp(from[7]);
  // to^-1 = (1 / s_to, q_to^-1, -(q_to^-1 t_to) / s_to).
  const Eigen::Quaternion<T> q_to_inv = q_to.conjugate();
  const Eigen::Matrix<T, 3, 1> t_to_inv = -(q_to_inv * t_to) * exp(-to[7]);
  // from * to^-1.
  const Eigen::Quaternion<T> q_a = q_from * q_to_inv;
  const Eigen::Matrix<T, 3, 1> t_a = s_from * (q_from * t_to_inv) + t_from;
  // measured * (from * to^-1).
  const Eigen::Quaternion<T> q_e = q_measured * q_a;
  const Eigen::Matrix<T, 3, 1> t_e = s_measured * (q_measured * t_a) + t_measured;
  residual[0] = t_e.x();
  residual[1] = t_e.y();
  residual[2] = t_e.z();
  // The sign of q is free: take the representative with w >= 0 so the error is small.
  const T sign = q_e.w() < T(0) ? T(-1) : T(1);
  residual[3] = T(2) * sign * q_e.x();
  residual[4] = T(2) * sign * q_e.y();
  residual[5] = T(2) * sign * q_e.z();
  residual[6] = log_s_measured + from[7] - to[7];
}

struct EdgeCost {
  EdgeCost(const Sim3d& measured, const Matrix7d& sqrt_information)
      : q_measured(measured.rotation.normalized()),
        t_measured(measured.translation),
        log_s_measured(std::log(measured.scale)),
        sqrt_information(sqrt_information) {}

  template <typename T>
  bool operator()(const T* from, const T* to, T* residual) const {
    Eigen::Matrix<T, 7, 1> e;
    RelativeError<T>(q_measured.cast<T>(), t_measured.cast<T>(), T(log_s_measured), from, to,
                     e.data());
    Eigen::Map<Eigen::Matrix<T, 7, 1>> out(residual);
    out = sqrt_information.cast<T>() * e;
    return true;
  }

  Eigen::Quaterniond q_measured;
  Eigen::Vector3d t_measured;
  double log_s_measured;
  Matrix7d sqrt_information;  // upper factor: sqrt_information^T sqrt_information = information
};

}  // namespace

std::string PoseGraphOptions::Problem() const {
  std::ostringstream out;
  if (max_iterations < 1) out << "max_iterations must be >= 1";
  else if (num_threads < 1) out << "num_threads must be >= 1";
  else if (!(function_tolerance >= 0.0)) out << "function_tolerance must be >= 0";
  return out.str();
}

Eigen::Matrix<double, 7, 1> PoseGraphResidual(const PoseGraphEdge& edge, const Sim3d& from,
                                              const Sim3d& to) {
  double from_params[kVertexSize], to_params[kVertexSize];
  VertexToParameters(from, from_params);
  VertexToParameters(to, to_params);
  Eigen::Matrix<double, 7, 1> residual;
  RelativeError<double>(edge.to_from_from.rotation.normalized(), edge.to_from_from.translation,
                        std::log(edge.to_from_from.scale), from_params, to_params,
                        residual.data());
  return residual;
}

PoseGraphReport OptimizePoseGraph(const PoseGraphOptions& options,
                                  const std::vector<PoseGraphEdge>& edges,
                                  std::vector<PoseGraphVertex>* vertices) {
  const auto start = std::chrono::steady_clock::now();
  const std::string options_problem = options.Problem();
  LCV_CHECK(options_problem.empty()) << options_problem;
  LCV_CHECK(vertices != nullptr);
  const int num_vertices = static_cast<int>(vertices->size());
  std::vector<double> params(kVertexSize * vertices->size());
  for (int i = 0; i < num_vertices; ++i) {
    VertexToParameters((*vertices)[i].cam_from_world, &params[kVertexSize * i]);
  }
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<4>> manifold{
      ceres::EigenQuaternionManifold(), ceres::EuclideanManifold<4>()};
  std::vector<char> used(vertices->size(), 0);
  for (size_t e = 0; e < edges.size(); ++e) {
    const PoseGraphEdge& edge = edges[e];
    LCV_CHECK(edge.from >= 0 && edge.from < num_vertices && edge.to >= 0 &&
              edge.to < num_vertices && edge.from != edge.to)
        << "edges[" << e << "]: vertices (" << edge.from << ", " << edge.to << ")";
    const Eigen::LLT<Matrix7d> llt(0.5 * (edge.information + edge.information.transpose()));
    LCV_CHECK(llt.info() == Eigen::Success) << "edges[" << e << "]: information not positive";
    const Matrix7d sqrt_information = llt.matrixU();
    for (const int v : {edge.from, edge.to}) {
      if (used[v]) continue;
      used[v] = 1;
      problem.AddParameterBlock(&params[kVertexSize * v], kVertexSize, &manifold);
      if ((*vertices)[v].fixed) problem.SetParameterBlockConstant(&params[kVertexSize * v]);
    }
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<EdgeCost, 7, kVertexSize, kVertexSize>(
            new EdgeCost(edge.to_from_from, sqrt_information)),
        nullptr, &params[kVertexSize * edge.from], &params[kVertexSize * edge.to]);
  }
  PoseGraphReport report;
  if (problem.NumResidualBlocks() == 0) {
    report.success = true;
    report.message = "no edges";
    return report;
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  if (!ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::SUITE_SPARSE) &&
      !ceres::IsSparseLinearAlgebraLibraryTypeAvailable(ceres::EIGEN_SPARSE)) {
    solver_options.linear_solver_type = ceres::DENSE_QR;
  }
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.num_threads = options.num_threads;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  report.success = summary.IsSolutionUsable();
  report.num_iterations = static_cast<int>(summary.iterations.size());
  report.initial_cost = summary.initial_cost;
  report.final_cost = summary.final_cost;
  report.message = summary.message;
  if (report.success) {
    for (int i = 0; i < num_vertices; ++i) {
      (*vertices)[i].cam_from_world = VertexFromParameters(&params[kVertexSize * i]);
    }
  }
  report.time_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace lcv::slam
