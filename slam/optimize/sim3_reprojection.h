#pragma once
// Sim(3) between two keyframes from 3D-3D matches, scored by reprojection in both images
// (ORB-SLAM2's Sim3Solver + Optimizer::OptimizeSim3, used by loop detection).
//
// A correspondence pairs a landmark of keyframe A (the query) with one of keyframe B (the
// match): point_in_a is A's landmark in A's camera frame, point_in_b is B's landmark in B's
// camera frame, px_a / px_b the keypoints that observe them. The model S = a_from_b (a
// similarity: monocular maps have drifted in scale) maps B's camera frame into A's:
//
//   r_a = Project_A(S * point_in_b) - px_a,      r_b = Project_B(S^-1 * point_in_a) - px_b,
//
// each whitened by the keypoint's octave (information = 1 / sigma^2, px^-2). The chi^2 of a
// correspondence is the larger of the two sides' whitened squared errors, so that a match must
// reproject well in both images, as ORB-SLAM's Sim3Solver::CheckInliers requires.
//
// Perturbation: S <- Exp(delta) * S with delta = [v; omega; sigma] (slam/geometry/sim3.h).
//
// Thread safety: stateless functions; the estimator is const and reentrant.

#include <vector>

#include <Eigen/Core>

#include "slam/camera/camera.h"
#include "slam/geometry/sim3.h"

namespace lcv::slam {

struct Sim3Correspondence {
  Eigen::Vector3d point_in_a = Eigen::Vector3d::Zero();  // A's landmark, A's camera frame
  Eigen::Vector3d point_in_b = Eigen::Vector3d::Zero();  // B's landmark, B's camera frame
  Eigen::Vector2d px_a = Eigen::Vector2d::Zero();
  Eigen::Vector2d px_b = Eigen::Vector2d::Zero();
  double information_a = 1.0;  // px^-2
  double information_b = 1.0;
};

// Residuals [r_a; r_b] (unwhitened, px) and optionally their 4x7 Jacobian with respect to delta
// at 0. Returns false when a side cannot be projected.
bool Sim3ReprojectionResidual(const Camera& camera_a, const Camera& camera_b,
                              const Sim3Correspondence& c, const Sim3d& a_from_b,
                              Eigen::Vector4d* residual,
                              Eigen::Matrix<double, 4, 7>* J_residual_delta = nullptr);

// max(information_a |r_a|^2, information_b |r_b|^2); infinity when a side cannot be projected.
double Sim3ReprojectionChi2(const Camera& camera_a, const Camera& camera_b,
                            const Sim3Correspondence& c, const Sim3d& a_from_b);

// RANSAC estimator (slam/solve/ransac.h): minimal sample of 3 solved by Umeyama (B's points onto
// A's, with scale); squared residual = Sim3ReprojectionChi2, so RansacOptions::max_error is
// sqrt(chi2 threshold) (ORB-SLAM: sqrt(9.21)). Refine: Umeyama on the inliers.
class Sim3ReprojectionEstimator {
 public:
  using Model = Sim3d;  // a_from_b
  static constexpr int kMinNumSamples = 3;

  // The data must outlive the estimator.
  Sim3ReprojectionEstimator(const Camera& camera_a, const Camera& camera_b,
                            const std::vector<Sim3Correspondence>& correspondences);

  int NumData() const { return static_cast<int>(correspondences_.size()); }
  void Estimate(const std::vector<int>& sample, std::vector<Model>* models) const;
  void Residuals(const Model& a_from_b, std::vector<double>* squared_residuals) const;
  bool Refine(const std::vector<int>& inliers, Model* a_from_b) const;

 private:
  const Camera& camera_a_;
  const Camera& camera_b_;
  const std::vector<Sim3Correspondence>& correspondences_;
  std::vector<Eigen::Vector3d> points_a_;
  std::vector<Eigen::Vector3d> points_b_;
};

struct Sim3RefineOptions {
  double chi2_threshold = 10.0;  // ORB-SLAM's OptimizeSim3 th2; also the Huber width (squared)
  int iterations = 5;            // per pass; a second pass runs without the outliers
};

struct Sim3RefineReport {
  int num_inliers = 0;
  std::vector<char> inlier_mask;  // per correspondence, 1 = chi^2 <= threshold at the end
};

// Gauss-Newton (Levenberg-damped) on the whitened residuals with a Huber kernel, then the
// outliers are dropped and it runs again (ORB-SLAM's OptimizeSim3). *a_from_b is updated only
// with steps that lower the cost.
Sim3RefineReport RefineSim3Reprojection(const Camera& camera_a, const Camera& camera_b,
                                        const std::vector<Sim3Correspondence>& correspondences,
                                        const Sim3RefineOptions& options, Sim3d* a_from_b);

}  // namespace lcv::slam
