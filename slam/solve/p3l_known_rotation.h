#pragma once
// The camera centre in a line cloud from three (or more) 2D point - 3D line correspondences
// when the rotation is known: a cheap hypothesis generator beside p6L (p6l.h) for a frame whose
// orientation is trusted but whose position is not (the live line-cloud check of a recovered
// pose, slam/tracking.h; orientation continues smoothly through a jump or dropped frames that
// throw the position off).
//
// Equation: with world_from_cam rotation R_wc and centre c, the viewing ray {c + s R_wc b_i} of
// bearing b_i meets the line {p_i + u d_i} iff (c - p_i) . (d_i x R_wc b_i) = 0, i.e.
//   n_i . c = n_i . p_i,   n_i = d_i x R_wc b_i,                                        (1)
// linear in c: three correspondences give a 3x3 system (the minimal sample), more give the
// least-squares centre. bench/bench_solve: 1.6 us a sample against p6L's 1.69 ms (OpenGV's
// six-point solver, 64 solutions); RANSAC on 70 matches with 45% outliers 0.26 ms against 441 ms.
// So a search over the centre fits in a live frame's budget where p6L's does not (docs/slam.md
// "The line-cloud check on a live camera").
//
// Residual: SquaredBearingPlaneError (p6l.h), the same as p6L's, so that both judge a pose
// alike. Degenerate: n_i (near) coplanar, e.g. all lines parallel to the bearings' plane, or
// rays along their lines: no candidate.
//
// Thread safety: reentrant; the estimator is const after construction.

#include <optional>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "slam/geometry/line3.h"
#include "slam/geometry/rigid3.h"
#include "slam/solve/p6l.h"
#include "slam/solve/ransac.h"

namespace lcv::slam {

// cam_from_world with the given rotation whose centre satisfies (1) for the correspondences in
// `indices` (least squares for more than three); nullopt when the system is degenerate (its
// smallest singular value below 1e-9 of the largest).
std::optional<Rigid3d> SolveCentreKnownRotation(const Eigen::Quaterniond& cam_from_world_rotation,
                                                const Eigen::Vector3d* bearings,
                                                const Line3d* world_lines,
                                                const std::vector<int>& indices);

// RANSAC estimator (ransac.h): minimal sample 3, SolveCentreKnownRotation; residual
// SquaredBearingPlaneError; Refine: the least-squares centre of the inliers (rotation fixed).
class CentreKnownRotationEstimator {
 public:
  using Model = Rigid3d;  // cam_from_world
  static constexpr int kMinNumSamples = 3;

  CentreKnownRotationEstimator(const Eigen::Quaterniond& cam_from_world_rotation,
                               const Eigen::Vector3d* bearings, const Line3d* world_lines,
                               int count)
      : rotation_(cam_from_world_rotation), bearings_(bearings), lines_(world_lines),
        count_(count) {}

  int NumData() const { return count_; }
  void Estimate(const std::vector<int>& sample, std::vector<Model>* models) const;
  void Residuals(const Model& cam_from_world, std::vector<double>* squared_residuals) const;
  bool Refine(const std::vector<int>& inliers, Model* cam_from_world) const;

 private:
  Eigen::Quaterniond rotation_;
  const Eigen::Vector3d* bearings_;
  const Line3d* lines_;
  int count_;
};

// RANSAC(CentreKnownRotationEstimator) with options.ransac (max_error 0: max_angular_error_rad),
// then RefineLineCloudPose (p6l.h): all six degrees of freedom refined on its inliers, so a
// rotation a little off is corrected. The result reads as EstimateP6L's.
P6LResult EstimatePoseKnownRotation(const std::vector<Eigen::Vector3d>& bearings,
                                    const std::vector<Line3d>& world_lines,
                                    const Eigen::Quaterniond& cam_from_world_rotation,
                                    const P6LOptions& options);

}  // namespace lcv::slam
