#include "slam/solve/umeyama.h"

#include <cmath>

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
