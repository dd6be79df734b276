#pragma once
// Homography between two perspective views of a plane, and its decomposition into motions.
//
// Equation: for a 3D point on the plane n^T p_in_cam1 = d (n unit, d > 0 the distance of
// camera 1 to the plane), with normalized image coordinates u_i = (p_in_cam_i / z_i) (z > 0),
//   u2 ~ H u1,   H = R + t n^T / d,   where cam2_from_cam1 = (R, t).
// Normalized coordinates exist only in front of the camera: the homography is for perspective
// images (ORB-SLAM uses it for planar or low-parallax scenes at initialization).
//
// Solver: normalized DLT (Hartley & Zisserman alg. 4.2) on count >= 4 pairs; degenerate when 3
// of a minimal sample are collinear (returns 0). Decomposition: Faugeras & Lustman 1988 as in
// ORB-SLAM's Initializer::ReconstructH, 8 candidate motions.

#include <vector>

#include <Eigen/Core>

namespace lcv::slam {

// H (up to scale; returned with unit Frobenius norm) from count >= 4 pairs of normalized image
// coordinates (u = x/z, v = y/z). Returns the number of solutions written (0 or 1).
int HomographyDlt(const Eigen::Vector2d* points1, const Eigen::Vector2d* points2, int count,
                  Eigen::Matrix3d* H);

// Symmetric transfer error: (|u2 - H u1|^2 + |u1 - H^-1 u2|^2) / 2 in normalized coordinates
// (radians^2 near the optical axis). H_inverse must be H.inverse().
double SquaredSymmetricTransferError(const Eigen::Matrix3d& H, const Eigen::Matrix3d& H_inverse,
                                     const Eigen::Vector2d& u1, const Eigen::Vector2d& u2);

// One motion explaining H = R + t n^T (up to scale): cam2_from_cam1 rotation, translation t/d
// (scaled by the inverse plane distance) and the unit plane normal n in camera 1. For the
// physically valid candidate, n^T p_in_cam1 = d > 0 on the plane.
struct HomographyMotion {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();  // = t_true / d
  Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
};

// The 8 Faugeras candidates, in pairs (R, t, n) / (R, -t, -n) of which only one places the
// points in front of the cameras (none when H's singular values are degenerate: d1 = d2 or
// d2 = d3 means pure rotation or no translation, for which the caller should not initialize).
// Writes to *motions (cleared first) and returns their count.
int DecomposeHomography(const Eigen::Matrix3d& H, std::vector<HomographyMotion>* motions);

// RANSAC estimator for H on normalized coordinate pairs; residual: the symmetric transfer
// error. Refine: DLT on all inliers. The arrays must outlive it.
class HomographyEstimator {
 public:
  using Model = Eigen::Matrix3d;
  static constexpr int kMinNumSamples = 4;

  HomographyEstimator(const Eigen::Vector2d* points1, const Eigen::Vector2d* points2, int count)
      : points1_(points1), points2_(points2), count_(count) {}

  int NumData() const { return count_; }
  void Estimate(const std::vector<int>& sample, std::vector<Model>* models) const;
  void Residuals(const Model& H, std::vector<double>* squared_residuals) const;
  bool Refine(const std::vector<int>& inliers, Model* H) const;

 private:
  const Eigen::Vector2d* points1_;
  const Eigen::Vector2d* points2_;
  int count_;
};

}  // namespace lcv::slam
