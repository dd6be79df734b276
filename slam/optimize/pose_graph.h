#pragma once
// Pose graph over Sim(3) (Strasdat et al., RSS 2010; ORB-SLAM's essential graph optimization)
// with Ceres: vertices are keyframe poses cam_from_world as similarities (monocular scale drift
// is a degree of freedom), edges relative similarities measured before the loop correction.
//
//   min sum_e r_e^T Omega_e r_e,   r_e = Residual(to_from_from_e * S_from * S_to^-1)
//
// with Residual(S) = [translation; 2 * quaternion.vec; log(scale)] (7-vector): zero at the
// identity and equal to Sim3d::Log() to first order (Ceres' pose_graph_3d example does the same
// for SE(3)); its Jacobians come from Ceres' automatic differentiation.
//
// Thread safety: the vertices are owned by the caller and not shared during the call.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "slam/geometry/sim3.h"
#include "slam/util/ids.h"

namespace lcv::slam {

using Matrix7d = Eigen::Matrix<double, 7, 7>;

struct PoseGraphVertex {
  Id id = kInvalidId;  // for the caller
  Sim3d cam_from_world;
  bool fixed = false;  // fix at least one (the loop's matched keyframe or the first one)
};

struct PoseGraphEdge {
  int from = -1;  // vertex indices
  int to = -1;
  // The measured cam_to_from_cam_from = S_to * S_from^-1 (for a loop edge: the Sim(3) found by
  // the loop detector; for covisibility/spanning-tree edges: the relative pose before the
  // correction, scale 1).
  Sim3d to_from_from;
  // Information of the residual [translation; 2 q.vec; log s]; identity weights all edges alike
  // (ORB-SLAM).
  Matrix7d information = Matrix7d::Identity();
};

struct PoseGraphOptions {
  int max_iterations = 20;
  int num_threads = 1;
  double function_tolerance = 1e-10;
  std::string Problem() const;
};

struct PoseGraphReport {
  bool success = false;
  int num_iterations = 0;
  double initial_cost = 0.0;
  double final_cost = 0.0;
  double time_ms = 0.0;
  std::string message;
};

// The residual above for one edge at the current vertex values (for tests and reports).
Eigen::Matrix<double, 7, 1> PoseGraphResidual(const PoseGraphEdge& edge, const Sim3d& from,
                                              const Sim3d& to);

// Optimizes the non-fixed vertices in place. Precondition: edge indices in range and
// options.Problem() empty (LCV_CHECK).
PoseGraphReport OptimizePoseGraph(const PoseGraphOptions& options,
                                  const std::vector<PoseGraphEdge>& edges,
                                  std::vector<PoseGraphVertex>* vertices);

}  // namespace lcv::slam
