#pragma once
// The residuals of the paper's bundle adjustments (Sec. 3.4) with analytic Jacobians, shared by
// the hand-written motion-only BA and the Ceres problems (local, global, rigid-stereo BA).
//
// Conventions
// - Poses are cam_from_world (slam/geometry/rigid3.h); Jacobians wrt a pose are wrt the left
//   perturbation defined there: T <- Exp(delta) * T, delta = [v; omega].
// - Residuals here are NOT whitened: callers multiply by the square root of the information
//   (pixel terms: sqrt(1 / sigma^2) for a keypoint detected at an octave with sigma^2 px^2).
// - Lines (slam/geometry/line3.h) are updated on a 4-dof tangent space, see RetractLine().
//
// Every function is pure and thread safe; none allocates.

#include <Eigen/Core>

#include "slam/camera/camera.h"
#include "slam/geometry/line3.h"
#include "slam/geometry/rigid3.h"

namespace lcv::slam {

using Matrix23d = Eigen::Matrix<double, 2, 3>;
using Matrix26d = Eigen::Matrix<double, 2, 6>;
using Matrix24d = Eigen::Matrix<double, 2, 4>;
using Matrix34d = Eigen::Matrix<double, 3, 4>;
using Matrix32d = Eigen::Matrix<double, 3, 2>;

// ---------------------------------------------------------------------------------------------
// e_pP (paper eq. 2): r = Project(cam_from_world * p_in_world) - observed_px, in pixels, through
// the camera model (perspective, fisheye, equirectangular alike).
// J_r_pose (2x6): wrt the left pose perturbation. J_r_point (2x3): wrt p_in_world.
// Returns false, leaving the outputs untouched, when the model cannot image the point (behind a
// perspective camera, beyond a fisheye's valid angle, at the camera centre).
bool ReprojectionResidual(const Camera& camera, const Rigid3d& cam_from_world,
                          const Eigen::Vector3d& p_in_world, const Eigen::Vector2d& observed_px,
                          Eigen::Vector2d* residual_px, Matrix26d* J_r_pose = nullptr,
                          Matrix23d* J_r_point = nullptr);

// ---------------------------------------------------------------------------------------------
// The line term of e_pL (paper eq. 3): ||X' - p_L||^2 under Omega_L, as a least-squares residual
//   r = S (I - d d^T) (X' - p_L),   S = SqrtInformation(Omega_L)   (3-vector, rank 2).
// For the line the information was computed for (d = d_0, the null direction of Omega_L) the
// projector changes nothing: r^T r = (X' - p_L)^T Omega_L (X' - p_L), the paper's term. It is
// there for lines that move (global BA): the residual stays independent of where X' lies along
// the CURRENT line, while S keeps the information of the conversion (a rotation of a line is a
// few milliradians in a BA, so re-deriving Omega_L is not worth its Jacobian).
// Units: map units times sqrt(Omega_L), i.e. dimensionless (a chi^2 with 2 dof).
// J_r_point (3x3): wrt X'. J_r_line (3x4): wrt the line's tangent (RetractLine()).
void PointToLineResidual(const Eigen::Vector3d& restored_point, const Line3d& line,
                         const Eigen::Matrix3d& sqrt_information, Eigen::Vector3d* residual,
                         Eigen::Matrix3d* J_r_point = nullptr, Matrix34d* J_r_line = nullptr);

// SqrtInformation(Omega_L): slam/geometry/line3.h.

// ---------------------------------------------------------------------------------------------
// Line tangent space (4 dof). With B = OrthonormalComplement(d) = [b1 b2] (b1 x b2 = d):
//   delta = [alpha (2); beta (2)]:  p_L <- p_L + B alpha,   d <- ExpSO3(B beta) * d.
// The anchor moves orthogonally to the line (moving it along d would not change the line: a
// gauge freedom) and the direction turns about the anchor on the sphere.
Line3d RetractLine(const Line3d& line, const Eigen::Vector4d& delta);

// Two unit vectors [b1 b2] orthogonal to the unit vector u, with b1 x b2 = u. Deterministic and
// smooth except where it switches its helper axis, so a tangent basis must be computed once per
// linearization point and reused for the update (as RetractLine() does).
Matrix32d OrthonormalComplement(const Eigen::Vector3d& u);

// ---------------------------------------------------------------------------------------------
// Virtual observation of a line by a server keyframe (paper eq. 4, Fig. 4d).
// n_L(P_ks, L): unit normal, in the camera frame, of the plane through the camera centre and the
// line: n = (a_c x d_c) / |a_c x d_c| with a_c = cam_from_world * p_L, d_c = R * d_L. Its sign
// follows d_L, so it is consistent while a line is optimized. Returns the zero vector when the
// line passes through the camera centre (|a_c x d_c| < 1e-12 * |a_c|).
Eigen::Vector3d LinePlaneNormal(const Rigid3d& cam_from_world, const Line3d& line);

// The paper's e_vL = (1 - n_L . n_v)^2 for reporting (unweighted). Quartic in the angle between
// the normals, so its Gauss-Newton Jacobian vanishes at the optimum: it is not what the solvers
// minimize (see VirtualObservationResidual).
double VirtualObservationError(const Rigid3d& cam_from_world, const Line3d& line,
                               const Eigen::Vector3d& observed_normal);

// Least-squares form of e_vL that the solvers use: r = B_v^T n_L (2-vector) with
// B_v = OrthonormalComplement(n_v). |r|^2 = sin^2(theta) = 2 (1 - n_L . n_v) + O(theta^4): the
// paper's quantity 1 - n_L . n_v, taken as the cost of a residual with a full-rank Jacobian at
// the optimum (theta is the angle between the normals, radians). Weight: Omega_vL = 1 / sigma^2
// with sigma in radians (see BundleOptions::virtual_sigma_rad).
// J_r_pose (2x6): wrt the server pose's left perturbation; J_r_line (2x4): wrt the line tangent.
// Returns false when the line passes through the camera centre; outputs untouched then.
bool VirtualObservationResidual(const Rigid3d& cam_from_world, const Line3d& line,
                                const Eigen::Vector3d& observed_normal,
                                Eigen::Vector2d* residual, Matrix26d* J_r_pose = nullptr,
                                Matrix24d* J_r_line = nullptr);

// Omega_vL, the information (2x2, rad^-2) of the residual of VirtualObservationResidual,
// propagated from the line's Omega_L (paper eq. 1) through the plane-normal function.
//
// Derivation. A published line is L = {p_L, d_L} with d_L drawn at random (exact, no
// uncertainty) and p_L uncertain only orthogonally to d_L: Omega_L is the information of the
// hidden point's offset from the line, so Sigma_perp = pinv(Omega_L) (rank 2, d_L in its null
// space) is the covariance of the line's position. To first order the residual moves by
//   dr = J_r_p dp_L,   J_r_p = d r / d p_L = -B_v^T (I - n n^T) / |m| [d_c]x R      (2x3)
// (m = a_c x d_c as in LinePlaneNormal; the anchor columns of J_r_line are J_r_p B), so
//   Sigma_r = J_r_p Sigma_perp J_r_p^T + sigma_floor^2 I,   Omega_vL = Sigma_r^-1.
// J_r_p has rank 1 (a shift of the line within its view plane leaves the plane unchanged, a
// shift across it turns the normal about d_c by |dp| / depth), so Sigma_r alone is singular: the
// floor sigma_floor_rad (the server pose's own angular uncertainty, and the model error of
// the linearization) keeps Omega_vL finite. For a point 10 m away with a 5 cm sigma the
// propagated sigma is ~5e-3 rad; a near, well-triangulated point reaches the floor.
// Evaluated at (cam_from_world, line); returns sigma_floor^-2 I when the line passes through the
// camera centre. Precondition: sigma_floor_rad > 0.
Eigen::Matrix2d VirtualObservationInformation(const Rigid3d& cam_from_world, const Line3d& line,
                                              const Eigen::Vector3d& observed_normal,
                                              const Eigen::Matrix3d& line_information,
                                              double sigma_floor_rad);

// Its symmetric square root, the whitening of VirtualObservationCost (what the solvers take).
Eigen::Matrix2d VirtualObservationSqrtInformation(const Rigid3d& cam_from_world,
                                                  const Line3d& line,
                                                  const Eigen::Vector3d& observed_normal,
                                                  const Eigen::Matrix3d& line_information,
                                                  double sigma_floor_rad);

// d r / d p_L of VirtualObservationResidual (2x3, see above). False at the camera centre.
bool VirtualObservationAnchorJacobian(const Rigid3d& cam_from_world, const Line3d& line,
                                      const Eigen::Vector3d& observed_normal,
                                      Eigen::Matrix<double, 2, 3>* J_r_anchor);

// Line-line intersection (map merging: an upload's line and the base line through the same
// point): the signed distance between `moving` and `fixed`,
//   r = (p_m - p_f) . c / |c|,   c = d_m x d_f,
// zero iff they meet (map units). J_r_line (1x4): wrt the tangent of `moving` (RetractLine()).
// False when the lines are parallel to within |c| < 1e-9 (outputs untouched).
bool LineIntersectionResidual(const Line3d& moving, const Line3d& fixed, double* residual,
                              Eigen::Matrix<double, 1, 4>* J_r_line = nullptr);

// SE(3) adjoint for [v; omega] tangents: Exp(Ad(T) delta) = T Exp(delta) T^-1, i.e.
// Ad = [[R, [t]x R], [0, R]]. Used where a pose is a fixed offset of an optimized one
// (rigid-stereo BA: cam_i_from_world = cam_i_from_ref * ref_from_world).
Eigen::Matrix<double, 6, 6> AdjointSE3(const Rigid3d& T);

// chi^2 quantiles at 95% used for outlier tests (ORB-SLAM's thresholds).
inline constexpr double kChi2Dof2 = 5.991;
inline constexpr double kChi2Dof3 = 7.815;
inline constexpr double kChi2Dof4 = 9.488;

}  // namespace lcv::slam
