#pragma once
// Least-squares similarity (or rigid) alignment of two 3D point sets with known correspondences:
//
//   dst_from_src = argmin_{s, R, t} sum_i |dst_i - (s * R * src_i + t)|^2,
//
// closed form by S. Umeyama, "Least-squares estimation of transformation parameters between
// two point patterns", IEEE PAMI 13(4), 1991 (eqs. 40-42). With estimate_scale = false, s = 1
// and the result is the rigid least-squares fit (Arun et al. 1987 with Umeyama's reflection
// fix). Used by trajectory evaluation (evo's --align / --correct_scale) and by the engine's
// point-point Sim(3) (3 correspondences, loop closing).
//
// Degeneracies: fewer than 3 points; all source points identical (no spread: scale undefined);
// collinear points (rank(Sigma_xy) < 2: rotation about the line undefined); non-finite input.
// These return false and leave the output untouched. Noise-free input gives the exact transform
// (to ~1e-12 relative). No throw, no allocation.

#include <cmath>
#include <vector>

#include <Eigen/Core>

#include "slam/geometry/sim3.h"

namespace lcv::slam {

// src[i] corresponds to dst[i], i < count. Returns false on degenerate input (see above).
bool AlignUmeyama(const Eigen::Vector3d* src, const Eigen::Vector3d* dst, int count,
                  bool estimate_scale, Sim3d* dst_from_src);

inline bool AlignUmeyama(const std::vector<Eigen::Vector3d>& src,
                         const std::vector<Eigen::Vector3d>& dst, bool estimate_scale,
                         Sim3d* dst_from_src) {
  if (src.size() != dst.size()) return false;
  return AlignUmeyama(src.data(), dst.data(), static_cast<int>(src.size()), estimate_scale,
                      dst_from_src);
}

// The similarity that takes a set of camera poses back onto other poses of the same cameras
// (a map's datum: LoopCloserOptions::keep_loaded_datum): world_dst = S * world_src, with
// cam_from_world_dst_i ~ cam_from_world_src_i * S^-1. The rotation is the chordal L2 mean of
// the cameras' own rotations R_dst_i^T R_src_i (projected onto SO(3) by SVD), not the rotation
// of the centres' point sets: the centres of a map driven along a street are nearly collinear,
// and the rotation about that line would follow noise (AlignUmeyama only rejects exact
// collinearity). Given the rotation, scale and translation are the least-squares fit of the
// centres (with estimate_scale = false, s = 1). Needs >= 2 poses with distinct centres (one
// for estimate_scale = false); false otherwise or on non-finite input, output untouched.
bool AlignPoseSets(const std::vector<Rigid3d>& src_cam_from_world,
                   const std::vector<Rigid3d>& dst_cam_from_world, bool estimate_scale,
                   Sim3d* dst_from_src);

// The eigenvalues (ascending) of the points' scatter about their mean, sum_i (c_i - m)(c_i - m)^T:
// the squared spreads of the points along their principal axes, times their count. Zero for
// fewer than two points. AlignMapDatum's planarity test, and trajectory evaluation's note on
// nearly straight paths (mapping/eval/trajectory_error.h).
Eigen::Vector3d PrincipalScatter(const std::vector<Eigen::Vector3d>& points);

// A map's datum (LoopCloserOptions::keep_loaded_datum, GlobalBACaptureOptions): the similarity
// that takes a map's keyframes (src) back onto their earlier poses (dst). The centres' fit
// (AlignUmeyama) when they span a plane, i.e. their second principal spread is at least
// kMinDatumSpreadRatio of the first; AlignPoseSets when they lie along a line (a street). Why
// both: after a loop the keyframes' rotations carry the drift the correction spread over them,
// and their mean moved the Table-3 maps 1.2-2x further than the centres' fit did; along a
// street, the centres leave the rotation about it to noise. False when neither applies.
// The centres' fit is also refused when it cannot pin the rotation about the spread's first
// axis: when that rotation's standard error (the fit's residual variance, 3n - 7 degrees of
// freedom, over the centres' squared spread across the axis) exceeds kMaxDatumCentreAngleRad.
// Three server keyframes along 18 degrees of a ring passed the spread test, and global BA's 4 cm
// reshaping of one turned their fit by 10 degrees (standard error 12 degrees; tests
// LineCloudGlobalBA.KeepsTheServerDatumAlongAStreet, AlignMapDatum.RefusesACentresFitItsResidual-
// CouldTurn). The 37 datum fits of the Table-3 runs (a city block, 41-60 keyframes) had at most
// 0.14 degrees and kept the centres' fit.
constexpr double kMinDatumSpreadRatio = 0.05;
constexpr double kMaxDatumCentreAngleRad = 2.0 * M_PI / 180.0;
bool AlignMapDatum(const std::vector<Rigid3d>& src_cam_from_world,
                   const std::vector<Rigid3d>& dst_cam_from_world, Sim3d* dst_from_src);

// RANSAC estimator (slam/solve/ransac.h) for dst ~ S * src with outliers: minimal sample of 3
// correspondences solved by AlignUmeyama, residual |dst_i - S * src_i| in dst units, Refine =
// AlignUmeyama on the inliers. The arrays must outlive the estimator.
class Sim3PointEstimator {
 public:
  using Model = Sim3d;  // dst_from_src
  static constexpr int kMinNumSamples = 3;

  Sim3PointEstimator(const Eigen::Vector3d* src, const Eigen::Vector3d* dst, int count,
                     bool estimate_scale = true)
      : src_(src), dst_(dst), count_(count), estimate_scale_(estimate_scale) {}

  int NumData() const { return count_; }
  void Estimate(const std::vector<int>& sample, std::vector<Model>* models) const;
  void Residuals(const Model& dst_from_src, std::vector<double>* squared_residuals) const;
  bool Refine(const std::vector<int>& inliers, Model* dst_from_src) const;

 private:
  const Eigen::Vector3d* src_;
  const Eigen::Vector3d* dst_;
  int count_;
  bool estimate_scale_;
};

}  // namespace lcv::slam
