#pragma once
// Camera pose from bearing/3D-point correspondences with outliers: P3P (p3p.h) in RANSAC,
// then Gauss-Newton on the tangent-plane errors of the inliers. Used by relocalization and by
// the tracker's recovery paths.
//
// Errors are angles on the unit sphere (bearing_error.h), so thresholds are in radians
// (~ px / focal_px) for every camera model.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "slam/geometry/rigid3.h"
#include "slam/solve/ransac.h"

namespace lcv::slam {

// RANSAC estimator: minimal solver SolveP3P, residual SquaredChordError of the point in the
// camera against its bearing, Refine: RefineAbsolutePose on the inliers. Arrays must outlive it.
class AbsolutePoseEstimator {
 public:
  using Model = Rigid3d;  // cam_from_world
  static constexpr int kMinNumSamples = 3;

  AbsolutePoseEstimator(const Eigen::Vector3d* bearings, const Eigen::Vector3d* points_in_world,
                        int count)
      : bearings_(bearings), points_(points_in_world), count_(count) {}

  int NumData() const { return count_; }
  void Estimate(const std::vector<int>& sample, std::vector<Model>* models) const;
  void Residuals(const Model& cam_from_world, std::vector<double>* squared_residuals) const;
  bool Refine(const std::vector<int>& inliers, Model* cam_from_world) const;

 private:
  const Eigen::Vector3d* bearings_;
  const Eigen::Vector3d* points_;
  int count_;
};

struct PoseRefinementOptions {
  int max_iterations = 10;
  // Huber threshold on the tangent error (radians); <= 0 for plain least squares.
  double huber_threshold_rad = 0.0;
  // Stop when the update is smaller than this (radians / map units).
  double min_step = 1e-10;
};

// Gauss-Newton (with step halving when the cost rises) on sum_i rho(|TangentError_i|^2) over
// the correspondences listed in `indices` (all `count` when null), starting from *cam_from_world,
// with the left perturbation of rigid3.h. Points behind the bearing (dot < 0) are skipped.
// Returns the number of iterations run, or -1 when fewer than 3 usable correspondences (then
// *cam_from_world is unchanged). Final cost (sum of squared tangent errors) in *final_cost.
int RefineAbsolutePose(const Eigen::Vector3d* bearings, const Eigen::Vector3d* points_in_world,
                       int count, const std::vector<int>* indices, const PoseRefinementOptions& options,
                       Rigid3d* cam_from_world, double* final_cost = nullptr);

struct AbsolutePoseOptions {
  RansacOptions ransac;  // ransac.max_error in radians; 0 here means "use max_angular_error_rad"
  double max_angular_error_rad = 0.004;
  int min_num_inliers = 10;
  bool refine = true;
  PoseRefinementOptions refinement;
};

struct AbsolutePoseResult {
  bool success = false;
  Rigid3d cam_from_world;
  int num_inliers = 0;
  int num_trials = 0;
  std::vector<char> inlier_mask;
};

// RANSAC(P3P) + refinement on the inliers (inliers re-evaluated after refinement).
AbsolutePoseResult EstimateAbsolutePose(const std::vector<Eigen::Vector3d>& bearings,
                                        const std::vector<Eigen::Vector3d>& points_in_world,
                                        const AbsolutePoseOptions& options);

}  // namespace lcv::slam
