#include "slam/solve/umeyama.h"

#include <cmath>
#include <vector>

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

namespace lcv::slam {

bool AlignUmeyama(const Eigen::Vector3d* src, const Eigen::Vector3d* dst, int count,
                  bool estimate_scale, Sim3d* dst_from_src) {
  if (count < 3 || src == nullptr || dst == nullptr || dst_from_src == nullptr) return false;
  Eigen::Vector3d mean_src = Eigen::Vector3d::Zero();
  Eigen::Vector3d mean_dst = Eigen::Vector3d::Zero();
  for (int i = 0; i < count; ++i) {
    mean_src += src[i];
    mean_dst += dst[i];
  }
  mean_src /= count;
  mean_dst /= count;
  if (!mean_src.allFinite() || !mean_dst.allFinite()) return false;

  // Sigma_xy = 1/n sum (dst_i - mu_dst)(src_i - mu_src)^T and sigma_src^2 (Umeyama eqs. 36-38),
  // on centred points for accuracy far from the origin.
  Eigen::Matrix3d sigma = Eigen::Matrix3d::Zero();
  double variance_src = 0.0;
  double variance_dst = 0.0;
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d s = src[i] - mean_src;
    const Eigen::Vector3d d = dst[i] - mean_dst;
    sigma.noalias() += d * s.transpose();
    variance_src += s.squaredNorm();
    variance_dst += d.squaredNorm();
  }
  sigma /= count;
  variance_src /= count;
  variance_dst /= count;
  // No spread in either set: nothing constrains rotation or scale.
  const double spread_floor = 1e-24 * (1.0 + mean_src.squaredNorm() + mean_dst.squaredNorm());
  if (!(variance_src > spread_floor) || !(variance_dst > spread_floor)) return false;

  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(sigma, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d singular = svd.singularValues();  // descending
  // rank(Sigma_xy) >= 2 is required for a unique rotation (Umeyama, Sec. III).
  if (!(singular(1) > 1e-12 * singular(0))) return false;

  const Eigen::Matrix3d& U = svd.matrixU();
  const Eigen::Matrix3d& V = svd.matrixV();
  // S = diag(1, 1, -1) when det(U) det(V) < 0, so that R is a rotation, not a reflection.
  Eigen::Vector3d S = Eigen::Vector3d::Ones();
  if (U.determinant() * V.determinant() < 0.0) S(2) = -1.0;
  const Eigen::Matrix3d R = U * S.asDiagonal() * V.transpose();
  const double scale = estimate_scale ? singular.dot(S) / variance_src : 1.0;
  if (!(scale > 0.0) || !std::isfinite(scale)) return false;

  Eigen::Quaterniond rotation(R);
  rotation.normalize();
  dst_from_src->scale = scale;
  dst_from_src->rotation = rotation;
  dst_from_src->translation = mean_dst - scale * (R * mean_src);
  return true;
}

bool AlignPoseSets(const std::vector<Rigid3d>& src_cam_from_world,
                   const std::vector<Rigid3d>& dst_cam_from_world, bool estimate_scale,
                   Sim3d* dst_from_src) {
  const size_t n = src_cam_from_world.size();
  if (n != dst_cam_from_world.size() || n < (estimate_scale ? 2u : 1u) || dst_from_src == nullptr) {
    return false;
  }
  // world_dst = s R world_src + t turns each camera's rotation: R_dst = R_src R^T, so every
  // camera gives R = R_dst^T R_src; their chordal mean is the SO(3) projection of the sum.
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  std::vector<Eigen::Vector3d> src_centres(n), dst_centres(n);
  for (size_t i = 0; i < n; ++i) {
    sum += dst_cam_from_world[i].RotationMatrix().transpose() *
           src_cam_from_world[i].RotationMatrix();
    src_centres[i] = src_cam_from_world[i].Center();
    dst_centres[i] = dst_cam_from_world[i].Center();
  }
  if (!sum.allFinite()) return false;
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(sum, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Vector3d S = Eigen::Vector3d::Ones();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) S(2) = -1.0;
  const Eigen::Matrix3d R = svd.matrixU() * S.asDiagonal() * svd.matrixV().transpose();

  Eigen::Vector3d mean_src = Eigen::Vector3d::Zero(), mean_dst = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    mean_src += R * src_centres[i];
    mean_dst += dst_centres[i];
  }
  mean_src /= static_cast<double>(n);
  mean_dst /= static_cast<double>(n);
  double scale = 1.0;
  if (estimate_scale) {
    double cross = 0.0, variance = 0.0;
    for (size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d a = R * src_centres[i] - mean_src;
      cross += a.dot(dst_centres[i] - mean_dst);
      variance += a.squaredNorm();
    }
    if (!(variance > 1e-24 * (1.0 + mean_src.squaredNorm()))) return false;
    scale = cross / variance;
  }
  if (!(scale > 0.0) || !std::isfinite(scale) || !mean_dst.allFinite()) return false;
  Eigen::Quaterniond rotation(R);
  rotation.normalize();
  dst_from_src->scale = scale;
  dst_from_src->rotation = rotation;
  dst_from_src->translation = mean_dst - scale * mean_src;
  return true;
}

Eigen::Vector3d PrincipalScatter(const std::vector<Eigen::Vector3d>& points) {
  if (points.size() < 2) return Eigen::Vector3d::Zero();
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& c : points) mean += c;
  mean /= static_cast<double>(points.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& c : points) scatter += (c - mean) * (c - mean).transpose();
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter).eigenvalues();
}

bool AlignMapDatum(const std::vector<Rigid3d>& src_cam_from_world,
                   const std::vector<Rigid3d>& dst_cam_from_world, Sim3d* dst_from_src) {
  const size_t n = src_cam_from_world.size();
  if (n != dst_cam_from_world.size() || n < 2) return false;
  std::vector<Eigen::Vector3d> src(n), dst(n);
  for (size_t i = 0; i < n; ++i) {
    src[i] = src_cam_from_world[i].Center();
    dst[i] = dst_cam_from_world[i].Center();
  }
  const Eigen::Vector3d eigenvalues = PrincipalScatter(dst);  // ascending
  const bool planar = n >= 3 && eigenvalues(2) > 0.0 &&
                      eigenvalues(1) >= kMinDatumSpreadRatio * kMinDatumSpreadRatio *
                                            eigenvalues(2);
  Sim3d by_centres;
  if (planar && AlignUmeyama(src, dst, /*estimate_scale=*/true, &by_centres)) {
    // How well the centres pin the rotation about the spread's first axis: the standard error
    // of that rotation, the residual's variance (3n - 7 degrees of freedom) over the centres'
    // squared spread across the axis. Nearly collinear centres reshaped by a few centimetres
    // can pass the spread test and still turn the map by degrees about the street.
    double squared_residual = 0.0;
    for (size_t i = 0; i < n; ++i) squared_residual += (dst[i] - by_centres * src[i]).squaredNorm();
    const double dof = 3.0 * static_cast<double>(n) - 7.0;
    const double across = eigenvalues(0) + eigenvalues(1);  // summed over the centres
    if (squared_residual / dof <= kMaxDatumCentreAngleRad * kMaxDatumCentreAngleRad * across) {
      *dst_from_src = by_centres;
      return true;
    }
  }
  return AlignPoseSets(src_cam_from_world, dst_cam_from_world, /*estimate_scale=*/true,
                       dst_from_src);
}

void Sim3PointEstimator::Estimate(const std::vector<int>& sample,
                                  std::vector<Model>* models) const {
  models->clear();
  if (sample.size() != 3) return;
  Eigen::Vector3d src[3], dst[3];
  for (int k = 0; k < 3; ++k) {
    src[k] = src_[sample[k]];
    dst[k] = dst_[sample[k]];
  }
  Sim3d model;
  if (AlignUmeyama(src, dst, 3, estimate_scale_, &model)) models->push_back(model);
}

void Sim3PointEstimator::Residuals(const Model& dst_from_src,
                                   std::vector<double>* squared_residuals) const {
  squared_residuals->resize(count_);
  const Eigen::Matrix3d sR = dst_from_src.scale * dst_from_src.rotation.toRotationMatrix();
  for (int i = 0; i < count_; ++i) {
    (*squared_residuals)[i] = (dst_[i] - (sR * src_[i] + dst_from_src.translation)).squaredNorm();
  }
}

bool Sim3PointEstimator::Refine(const std::vector<int>& inliers, Model* dst_from_src) const {
  std::vector<Eigen::Vector3d> src, dst;
  src.reserve(inliers.size());
  dst.reserve(inliers.size());
  for (const int i : inliers) {
    src.push_back(src_[i]);
    dst.push_back(dst_[i]);
  }
  return AlignUmeyama(src, dst, estimate_scale_, dst_from_src);
}

}  // namespace lcv::slam
