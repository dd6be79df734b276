#pragma once
// Similarity between a client map and a server line cloud from 3D point - 3D line
// correspondences (the registration of paper Sec. 3.3, loop closing and relocalization against
// a line cloud).
//
// Equation: the client point X_i (client world frame), mapped by the unknown
//   server_from_client = (s, R, t):  Y_i = s R X_i + t,
// lies on the server line L_i = {p_i, d_i} (d_i unit):
//   (I - d_i d_i^T) (s R X_i + t - p_i) = 0,   two independent equations per correspondence.
//
// Solvers here:
// - SolveSim3PointLineLinear: 6 or more correspondences, linear in M = s R and t (12 unknowns,
//   2 equations each), then M projected to the nearest scaled rotation and t re-solved. The
//   4-correspondence solver of the paper is SolveP4L (p4l.h): fewer RANSAC samples, but each
//   minimal solve costs ~0.1 ms against a few microseconds here.
// - RefineSim3PointLine: Gauss-Newton on the 2D point-to-line residuals, 7 DoF.
// Degenerate (rank-deficient linear system: 0 solutions, never NaN): fewer than 6
// correspondences, all lines parallel (translation along them unobservable), collinear points.

#include <vector>

#include <Eigen/Core>

#include "slam/geometry/line3.h"
#include "slam/geometry/sim3.h"

namespace lcv::slam {

// server_from_client from count >= 6 correspondences (indices: a subset, or all when null).
// Returns the number of solutions written (0 or 1).
int SolveSim3PointLineLinear(const Eigen::Vector3d* points_in_client, const Line3d* server_lines,
                             int count, const std::vector<int>* indices,
                             Sim3d* server_from_client);

// Squared distance (server units^2) of S * X to the line.
double SquaredPointLineDistance(const Sim3d& server_from_client, const Eigen::Vector3d& point,
                                const Line3d& line);

// Gauss-Newton (step halving on cost increase) on sum_i |B_i^T (S X_i - p_i)|^2, B_i an
// orthonormal basis orthogonal to d_i, with the left perturbation S <- Exp(delta) S of
// sim3.h (delta = [v; omega; sigma]). Returns iterations run, or -1 with fewer than 4 usable
// correspondences (S unchanged). Final cost in *final_cost when given.
int RefineSim3PointLine(const Eigen::Vector3d* points_in_client, const Line3d* server_lines,
                        int count, const std::vector<int>* indices, int max_iterations,
                        Sim3d* server_from_client, double* final_cost = nullptr);

// RANSAC estimator (ransac.h): minimal sample 6, SolveSim3PointLineLinear; residual
// SquaredPointLineDistance (threshold in server units); Refine: RefineSim3PointLine on the
// inliers. The arrays must outlive it.
class Sim3PointLineEstimator {
 public:
  using Model = Sim3d;  // server_from_client
  static constexpr int kMinNumSamples = 6;

  Sim3PointLineEstimator(const Eigen::Vector3d* points_in_client, const Line3d* server_lines,
                         int count)
      : points_(points_in_client), lines_(server_lines), count_(count) {}

  int NumData() const { return count_; }
  void Estimate(const std::vector<int>& sample, std::vector<Model>* models) const;
  void Residuals(const Model& server_from_client, std::vector<double>* squared_residuals) const;
  bool Refine(const std::vector<int>& inliers, Model* server_from_client) const;

 private:
  const Eigen::Vector3d* points_;
  const Line3d* lines_;
  int count_;
};

}  // namespace lcv::slam
