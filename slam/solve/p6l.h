#pragma once
// p6L: the pose of a central camera in a line cloud from six (or more) 2D point - 3D line
// correspondences (Speciale, Schoenberger, Kang, Sinha, Pollefeys, "Privacy Preserving
// Image-Based Localization", CVPR 2019). The project's baseline per-frame localizer in a line
// cloud (the LC-VSLAM relocalizer uses P4L/P3P on a client map instead, p4l.h).
//
// Equation: the viewing ray of bearing b_i (unit, camera frame) meets the map line
// L_i = {p_i, d_i} (world frame). With world_from_cam = (R, t), the ray is {t, R b_i}; two lines
// meet iff their Pluecker coordinates are reciprocal:
//   (d_i x R b_i) . t + d_i^T [p_i]_x R b_i = 0,                                   (1)
// the generalized epipolar constraint of a generalized camera (the map: one "camera" per line,
// centre p_i, bearing d_i) and a central one (the query). Six equations fix R (Stewenius et al.,
// "Solutions to minimal generalized relative pose problems", OMNIVIS 2005: up to 64 complex
// solutions, OpenGV's `relative_pose::sixpt`). For each real R, (1) is linear in [t; 1]: t is the
// null vector of G = sum_i g_i g_i^T, g_i = [d_i x R b_i; d_i^T [p_i]_x R b_i], taken as the
// eigenvector of the SMALLEST eigenvalue (Debian's OpenGV takes eigenvector 0 of an unsorted
// solver inside its SAC problem and returns wrong translations: ARCHITECTURE.md; this file does
// not use OpenGV's SAC problem or its scoring, which also assumes consistently oriented lines).
//
// Residual (orientation-free, so random line directions are fine): the sine of the angle between
// the bearing and the plane through the camera centre and the line, |b . n| / |n| with
// n = a x d_c (a, d_c the anchor and direction in the camera frame); radians for small angles,
// so one threshold serves perspective, fisheye and equirectangular cameras (bearing_error.h).
// A bearing whose ray meets the line behind the camera (negative depth) scores the maximum (4).
//
// Degenerate: fewer than 6 correspondences; lines through the camera centre; all lines through
// one point or all parallel (translation unobservable). Returns 0 candidates, never NaN.
// OpenGV stays in p6l.cc (linked PRIVATE).
//
// Thread safety: all functions are reentrant; P6LEstimator is const after construction.

#include <vector>

#include <Eigen/Core>

#include "slam/geometry/line3.h"
#include "slam/geometry/rigid3.h"
#include "slam/solve/ransac.h"

namespace lcv::slam {

// cam_from_world candidates (cleared first) from the first 6 correspondences; candidates that put
// any of the 6 ray-line meeting points behind the camera are dropped. Returns their count (0..64).
int SolveP6L(const Eigen::Vector3d* bearings, const Line3d* world_lines, int count,
             std::vector<Rigid3d>* cam_from_world);

// Squared residual defined above (sin^2 of the bearing-plane angle, in [0, 1]; 4 when the ray
// meets the line behind the camera or the line passes through the camera centre).
double SquaredBearingPlaneError(const Rigid3d& cam_from_world, const Eigen::Vector3d& bearing,
                                const Line3d& world_line);

// The signed residual r = b . n / |n| and its 1x6 Jacobian with respect to the left perturbation
// of cam_from_world (rigid3.h: [v; omega]). False when the line passes through the camera centre.
// The sign of r follows the line's orientation; r^2 does not.
bool BearingPlaneResidual(const Rigid3d& cam_from_world, const Eigen::Vector3d& bearing,
                          const Line3d& world_line, double* residual,
                          Eigen::Matrix<double, 1, 6>* jacobian);

struct P6LRefinementOptions {
  int max_iterations = 15;
  // Huber threshold on the residual (radians); <= 0 for plain least squares.
  double huber_threshold_rad = 0.0;
  double min_step = 1e-10;  // stop when |delta| (radians / map units) is below
};

// Gauss-Newton (with step halving when the cost rises) on sum_i rho(r_i^2) over the
// correspondences in `indices` (all `count` when null), from *cam_from_world. Correspondences
// that score 4 (behind the camera) at the start are skipped. Returns the iterations run, or -1
// with *cam_from_world unchanged when fewer than 6 are usable or the normal equations are
// singular. Final cost (sum of squared residuals) in *final_cost.
int RefineP6L(const Eigen::Vector3d* bearings, const Line3d* world_lines, int count,
              const std::vector<int>* indices, const P6LRefinementOptions& options,
              Rigid3d* cam_from_world, double* final_cost = nullptr);

// RANSAC estimator (ransac.h): minimal sample 6, SolveP6L; residual SquaredBearingPlaneError;
// Refine: RefineP6L on the inliers. Arrays must outlive it.
class P6LEstimator {
 public:
  using Model = Rigid3d;  // cam_from_world
  static constexpr int kMinNumSamples = 6;

  P6LEstimator(const Eigen::Vector3d* bearings, const Line3d* world_lines, int count)
      : bearings_(bearings), lines_(world_lines), count_(count) {}

  int NumData() const { return count_; }
  void Estimate(const std::vector<int>& sample, std::vector<Model>* models) const;
  void Residuals(const Model& cam_from_world, std::vector<double>* squared_residuals) const;
  bool Refine(const std::vector<int>& inliers, Model* cam_from_world) const;

 private:
  const Eigen::Vector3d* bearings_;
  const Line3d* lines_;
  int count_;
};

struct P6LOptions {
  RansacOptions ransac;  // ransac.max_error 0 here means "use max_angular_error_rad"
  double max_angular_error_rad = 0.004;
  int min_num_inliers = 12;
  bool refine = true;
  P6LRefinementOptions refinement;
};

struct P6LResult {
  bool success = false;
  Rigid3d cam_from_world;
  int num_inliers = 0;
  int num_trials = 0;
  bool stopped_early = false;  // options.ransac.should_stop ended RANSAC's sampling
  std::vector<char> inlier_mask;
};

// RANSAC(p6L) + refinement on the inliers (inliers re-evaluated after refinement). Success needs
// min_num_inliers inliers and RANSAC's min_inlier_ratio.
P6LResult EstimateP6L(const std::vector<Eigen::Vector3d>& bearings,
                      const std::vector<Line3d>& world_lines, const P6LOptions& options);

// The part of EstimateP6L after RANSAC, for a RANSAC of any pose estimator over the same data
// and residual (p3l_known_rotation.h): when options.refine, RefineP6L (all six degrees of
// freedom) on the report's inliers and the inliers re-evaluated (the RANSAC model kept when the
// refinement fails); success as EstimateP6L's. max_error: the RANSAC threshold used.
P6LResult RefineLineCloudPose(const RansacReport<Rigid3d>& report,
                              const std::vector<Eigen::Vector3d>& bearings,
                              const std::vector<Line3d>& world_lines, const P6LOptions& options,
                              double max_error);

}  // namespace lcv::slam
