#pragma once
// P4L: Sim(3) from four (or more) 3D point - 3D line correspondences (paper Sec. 3.3, loop
// closing and relocalization against a line cloud; the paper uses gDLS, Sweeney et al.,
// "gDLS: A Scalable Solution to the Generalized Pose and Scale Problem", ECCV 2014).
//
// Equation: client point X_i, server line L_i = {p_i, d_i}. With the scale put on the server
// side, as gDLS does,
//   R X_i + t = s (p_i + a_i d_i)        (a_i the position of the point on its line),
// which is linear in (t, s, a_i) for a given rotation R. Eliminating them leaves a quadratic
// form in the entries of R: J(R) = vec(R)^T M vec(R) (M 9x9, PSD), zero at every exact
// solution. server_from_client = (1/s, R, t/s).
//
// Method: gDLS finds all stationary points of J on SO(3) with a Groebner basis. Here J is
// minimized by Gauss-Newton on SO(3) from the 24 rotations of the cube group (no rotation is
// more than 62.8 degrees from one of them), keeping the distinct minima. With exact data the
// true solution is among them to ~1e-10 in practice (tested), but unlike gDLS the search is
// not guaranteed to find every solution of a minimal problem: up to 4 candidates are
// returned, lowest J first, for RANSAC to score.
//
// Degenerate: fewer than 4 correspondences; all lines parallel or through one point (scale or
// translation unobservable); collinear points. Returns 0, never NaN.

#include <vector>

#include <Eigen/Core>

#include "slam/geometry/line3.h"
#include "slam/geometry/sim3.h"

namespace lcv::slam {

// server_from_client candidates (cleared first), returns their count (0..4).
int SolveP4L(const Eigen::Vector3d* points_in_client, const Line3d* server_lines, int count,
             std::vector<Sim3d>* server_from_client);

// RANSAC estimator (ransac.h): minimal sample 4, SolveP4L; residual SquaredPointLineDistance
// (point_line_sim3.h, server units^2); Refine: RefineSim3PointLine on the inliers.
class P4LEstimator {
 public:
  using Model = Sim3d;  // server_from_client
  static constexpr int kMinNumSamples = 4;

  P4LEstimator(const Eigen::Vector3d* points_in_client, const Line3d* server_lines, int count)
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
