#pragma once
// Rigid-stereo BA (paper eq. 8), for relocalization and loop detection against a line cloud:
// the pose of the current keyframe P_kc^ckf and the restored points X' of matched lines are
// optimized, while the neighbouring keyframes move rigidly with it (their poses relative to the
// current keyframe, Delta P^i, are constant):
//
//   P*, X'* = argmin sum_i sum_j rho(e_pP(Delta P^i P, X'^j, x'^ij) + w_L ||X'^j - p_L^j||^2_Omega_L)
//
// Ceres (Schur over the X'); Jacobians wrt P through the SE(3) adjoint of Delta P^i. Outliers
// as in SolveBundleAdjustment: Huber pass, flag by chi^2 (4 dof), then a pass without them.
// Points already restored on the server side can join as fixed X' (RigidStereoLine::fixed).

#include <string>
#include <vector>

#include <Eigen/Core>

#include "slam/camera/camera.h"
#include "slam/geometry/line3.h"
#include "slam/geometry/rigid3.h"
#include "slam/optimize/bundle_adjustment.h"

namespace lcv::slam {

struct RigidStereoView {
  Rigid3d cam_from_reference;      // Delta P^i (identity for the current keyframe)
  const Camera* camera = nullptr;  // not owned
};

struct RigidStereoLine {
  Line3d line;  // fixed
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();  // Omega_L
  Eigen::Vector3d restored_point = Eigen::Vector3d::Zero();  // X', in/out
  // True for a point already restored on the server side (a 3D point-3D point match of the
  // registration): X' is held constant at restored_point, so only its reprojections constrain
  // the pose; the line part is dropped and its chi^2 has 2 dof (point_chi2_threshold).
  bool fixed = false;
};

struct RigidStereoObservation {
  int view = -1;  // index into the views
  int line = -1;  // index into the lines
  Eigen::Vector2d observed_px = Eigen::Vector2d::Zero();
  double information = 1.0;  // px^-2
  bool outlier = false;      // in: excluded; out: final classification
  double chi2 = 0.0;         // out
};

// Refines *reference_cam_from_world (P_kc^ckf) and the lines' restored points in place. The pose
// is written only on success; the restored points are updated by Ceres in place either way.
// group_scale (optional, beyond Eq. 7): when given (> 0), every view's offset translation is
// multiplied by *group_scale, which is optimized too and written on success: the scale of a
// monocular rigid group whose baselines come from an uncertain similarity. Observable only
// when views other than the reference see the points.
// Uses options' iterations, thresholds, line_weight and threads (virtual_sigma_rad unused).
// Precondition: indices in range, cameras set (LCV_CHECK).
BundleReport SolveRigidStereoBA(const BundleOptions& options,
                                const std::vector<RigidStereoView>& views,
                                Rigid3d* reference_cam_from_world,
                                std::vector<RigidStereoLine>* lines,
                                std::vector<RigidStereoObservation>* observations,
                                double* group_scale = nullptr);

}  // namespace lcv::slam
