#pragma once
// Essential matrix from bearing correspondences and its decomposition.
//
// Equation: for a point seen along unit bearing x1 in camera 1 and x2 in camera 2,
//   x2^T E x1 = 0,   E = [t]x R,   where cam2_from_cam1 = (R, t): p_in_cam2 = R p_in_cam1 + t.
// Works on bearings, so any central camera (including > 180 degree fields of view) is fine.
//
// Solver: the normalized eight-point algorithm (Hartley 1997) on bearings, with the singular
// values of E projected to (1, 1, 0). Degenerate: fewer than 8 pairs, all points on a plane
// together with the camera centres ("critical surfaces"), pure rotation (t = 0: E is then
// undefined; use the homography or detect low parallax). Returns 0 in those cases when the
// linear system shows it (rank deficiency), never NaN.

#include <vector>

#include <Eigen/Core>

#include "slam/geometry/rigid3.h"

namespace lcv::slam {

// E with ||E||_F = sqrt(2) from count >= 8 bearing pairs (unit or not: they are normalized
// internally). Returns the number of solutions written to *E (0 or 1).
int EssentialMatrixEightPoint(const Eigen::Vector3d* bearings1, const Eigen::Vector3d* bearings2,
                              int count, Eigen::Matrix3d* E);

// Seven-point solver (Hartley & Zisserman 11.1.2) on exactly 7 bearing pairs: the 2-dim null
// space of the linear system, det(E) = 0 as a cubic, each real root projected onto the
// essential manifold. Up to 3 candidates written to *E (cleared first), returns the count.
// Only the root matching a true essential matrix is exact; RANSAC scores the others away.
// RANSAC needs ~half the samples of the eight-point solver (7 vs 8 per sample).
int EssentialMatrixSevenPoint(const Eigen::Vector3d* bearings1, const Eigen::Vector3d* bearings2,
                              std::vector<Eigen::Matrix3d>* E);

// The four motions (R1, t), (R1, -t), (R2, t), (R2, -t) consistent with E, with |t| = 1
// (Hartley & Zisserman, result 9.19). Only one places the points in front of both cameras.
void DecomposeEssentialMatrix(const Eigen::Matrix3d& E, Eigen::Matrix3d* R1, Eigen::Matrix3d* R2,
                              Eigen::Vector3d* t);

// Squared distance of a bearing pair to E's epipolar constraint, as the mean of the squared
// sines of the angles between x2 and the epipolar plane E x1 and between x1 and the plane
// E^T x2 (radians^2 for small errors; compare with RansacOptions::max_error^2). Infinite-like
// (1) when a bearing is an epipole.
double SquaredEpipolarAngleError(const Eigen::Matrix3d& E, const Eigen::Vector3d& x1,
                                 const Eigen::Vector3d& x2);

// Chooses among the four decompositions of E the motion that puts the most pairs (among those
// with mask[i] != 0; all when mask is null) at positive depth along both bearings, triangulated
// with the midpoint method. Writes cam2_from_cam1 (|t| = 1) and returns that count (0 when E
// is degenerate).
int PoseFromEssentialMatrix(const Eigen::Matrix3d& E, const Eigen::Vector3d* bearings1,
                            const Eigen::Vector3d* bearings2, int count, const char* mask,
                            Rigid3d* cam2_from_cam1);

// Signed sine of the angle between x2 and the epipolar plane of x1 under cam2_from_cam1 =
// (R, t): r = x2 . n / |n|, n = t x (R x1) (x2 unit). 0 when n vanishes (x1 at the epipole).
double EpipolarSine(const Rigid3d& cam2_from_cam1, const Eigen::Vector3d& x1,
                    const Eigen::Vector3d& x2);

// Gauss-Newton on sum_i EpipolarSine_i^2 over the pairs listed in `indices` (all `count` when
// null), starting from *cam2_from_cam1, keeping |t| = 1: rotation perturbed on the left
// (R <- Exp(omega) R), translation in the tangent plane of the unit sphere. The eight-point
// solution minimizes an algebraic error; this refines it to the geometric one (better rotation
// by a factor ~2-5 on real matches). Returns the iterations run, -1 with fewer than 5 usable
// pairs (pose unchanged).
int RefineRelativePose(const Eigen::Vector3d* bearings1, const Eigen::Vector3d* bearings2,
                       int count, const std::vector<int>* indices, int max_iterations,
                       Rigid3d* cam2_from_cam1);

// RANSAC estimator (slam/solve/ransac.h) for E on bearing pairs: minimal samples of 7 through
// EssentialMatrixSevenPoint; residual: SquaredEpipolarAngleError. Refine: eight-point on all
// inliers. The bearings must be unit vectors; the arrays must outlive the estimator.
class EssentialMatrixEstimator {
 public:
  using Model = Eigen::Matrix3d;
  static constexpr int kMinNumSamples = 7;

  EssentialMatrixEstimator(const Eigen::Vector3d* bearings1, const Eigen::Vector3d* bearings2,
                           int count)
      : bearings1_(bearings1), bearings2_(bearings2), count_(count) {}

  int NumData() const { return count_; }
  void Estimate(const std::vector<int>& sample, std::vector<Model>* models) const;
  void Residuals(const Model& E, std::vector<double>* squared_residuals) const;
  bool Refine(const std::vector<int>& inliers, Model* E) const;

 private:
  const Eigen::Vector3d* bearings1_;
  const Eigen::Vector3d* bearings2_;
  int count_;
};

}  // namespace lcv::slam
