#include "slam/solve/homography.h"

#include <cmath>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/SVD>

namespace lcv::slam {
namespace {

// Hartley normalization: centroid to the origin, mean distance sqrt(2).
Eigen::Matrix3d NormalizingTransform(const Eigen::Vector2d* points, int count,
                                     const std::vector<int>* indices) {
  const int n = indices ? static_cast<int>(indices->size()) : count;
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  for (int k = 0; k < n; ++k) centroid += points[indices ? (*indices)[k] : k];
  centroid /= n;
  double mean_distance = 0.0;
  for (int k = 0; k < n; ++k) mean_distance += (points[indices ? (*indices)[k] : k] - centroid).norm();
  mean_distance /= n;
  const double scale = mean_distance > 1e-15 ? std::sqrt(2.0) / mean_distance : 1.0;
  Eigen::Matrix3d T;
  T << scale, 0, -scale * centroid.x(), 0, scale, -scale * centroid.y(), 0, 0, 1;
  return T;
}

// |cross(b - a, c - a)| relative to the squared edge lengths: ~0 for collinear points.
bool Collinear(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  const Eigen::Vector2d ab = b - a;
  const Eigen::Vector2d ac = c - a;
  const double cross = ab.x() * ac.y() - ab.y() * ac.x();
  return std::abs(cross) <= 1e-9 * (ab.squaredNorm() + ac.squaredNorm()) + 1e-300;
}

int Dlt(const Eigen::Vector2d* points1, const Eigen::Vector2d* points2, int count,
        const std::vector<int>* indices, Eigen::Matrix3d* H) {
  const int n = indices ? static_cast<int>(indices->size()) : count;
  if (n < 4) return 0;
  if (n == 4) {
    // A minimal sample with three collinear points in either image has no unique H.
    int ids[4];
    for (int k = 0; k < 4; ++k) ids[k] = indices ? (*indices)[k] : k;
    for (const Eigen::Vector2d* points : {points1, points2}) {
      for (int skip = 0; skip < 4; ++skip) {
        int tri[3], m = 0;
        for (int k = 0; k < 4; ++k) {
          if (k != skip) tri[m++] = ids[k];
        }
        if (Collinear(points[tri[0]], points[tri[1]], points[tri[2]])) return 0;
      }
    }
  }
  const Eigen::Matrix3d T1 = NormalizingTransform(points1, count, indices);
  const Eigen::Matrix3d T2 = NormalizingTransform(points2, count, indices);
  Eigen::Matrix<double, 9, 9> AtA = Eigen::Matrix<double, 9, 9>::Zero();
  for (int k = 0; k < n; ++k) {
    const int i = indices ? (*indices)[k] : k;
    const Eigen::Vector3d p1 = T1 * points1[i].homogeneous();
    const Eigen::Vector3d p2 = T2 * points2[i].homogeneous();
    // p2 x (H p1) = 0: two independent rows.
    Eigen::Matrix<double, 9, 1> row1, row2;
    row1 << 0, 0, 0, -p2.z() * p1, p2.y() * p1;
    row2 << p2.z() * p1, 0, 0, 0, -p2.x() * p1;
    AtA.selfadjointView<Eigen::Lower>().rankUpdate(row1);
    AtA.selfadjointView<Eigen::Lower>().rankUpdate(row2);
  }
  AtA = AtA.selfadjointView<Eigen::Lower>();
  if (!AtA.allFinite()) return 0;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eigen(AtA);
  if (eigen.info() != Eigen::Success) return 0;
  if (!(eigen.eigenvalues()(1) > 1e-12 * eigen.eigenvalues()(8))) return 0;
  const Eigen::Matrix<double, 9, 1> h = eigen.eigenvectors().col(0);
  Eigen::Matrix3d Hn;
  Hn << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);
  Eigen::Matrix3d result = T2.inverse() * Hn * T1;
  const double norm = result.norm();
  if (!(norm > 0.0) || !result.allFinite()) return 0;
  result /= norm;
  if (std::abs(result.determinant()) < 1e-14) return 0;
  *H = result;
  return 1;
}

}  // namespace

int HomographyDlt(const Eigen::Vector2d* points1, const Eigen::Vector2d* points2, int count,
                  Eigen::Matrix3d* H) {
  return Dlt(points1, points2, count, nullptr, H);
}

double SquaredSymmetricTransferError(const Eigen::Matrix3d& H, const Eigen::Matrix3d& H_inverse,
                                     const Eigen::Vector2d& u1, const Eigen::Vector2d& u2) {
  const Eigen::Vector3d forward = H * u1.homogeneous();
  const Eigen::Vector3d backward = H_inverse * u2.homogeneous();
  // A point mapped to infinity (or behind, w <= 0 in the limit) is an outlier.
  if (std::abs(forward.z()) < 1e-12 || std::abs(backward.z()) < 1e-12) return 1e6;
  const double e2 = (forward.hnormalized() - u2).squaredNorm();
  const double e1 = (backward.hnormalized() - u1).squaredNorm();
  return 0.5 * (e1 + e2);
}

int DecomposeHomography(const Eigen::Matrix3d& H, std::vector<HomographyMotion>* motions) {
  motions->clear();
  if (!H.allFinite()) return 0;
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d U = svd.matrixU();
  const Eigen::Matrix3d V = svd.matrixV();
  const double s = U.determinant() * V.determinant();
  const double d1 = svd.singularValues()(0);
  const double d2 = svd.singularValues()(1);
  const double d3 = svd.singularValues()(2);
  // Equal singular values: no translation or a degenerate plane; the motion is not observable.
  if (!(d3 > 0.0) || d1 / d2 < 1.00001 || d2 / d3 < 1.00001) return 0;

  const double d1s = d1 * d1, d2s = d2 * d2, d3s = d3 * d3;
  const double aux1 = std::sqrt((d1s - d2s) / (d1s - d3s));
  const double aux3 = std::sqrt((d2s - d3s) / (d1s - d3s));
  const double x1[4] = {aux1, aux1, -aux1, -aux1};
  const double x3[4] = {aux3, -aux3, aux3, -aux3};

  std::vector<std::pair<Eigen::Matrix3d, Eigen::Vector3d>> candidates;  // (R, n)
  candidates.reserve(8);
  // Case d' = d2 > 0 (Faugeras & Lustman 1988).
  const double sin_theta = std::sqrt((d1s - d2s) * (d2s - d3s)) / ((d1 + d3) * d2);
  const double cos_theta = (d2s + d1 * d3) / ((d1 + d3) * d2);
  const double sin_thetas[4] = {sin_theta, -sin_theta, -sin_theta, sin_theta};
  for (int i = 0; i < 4; ++i) {
    Eigen::Matrix3d Rp;
    Rp << cos_theta, 0, -sin_thetas[i], 0, 1, 0, sin_thetas[i], 0, cos_theta;
    candidates.emplace_back(s * U * Rp * V.transpose(), V * Eigen::Vector3d(x1[i], 0, x3[i]));
  }
  // Case d' = -d2 < 0.
  const double sin_phi = std::sqrt((d1s - d2s) * (d2s - d3s)) / ((d1 - d3) * d2);
  const double cos_phi = (d1 * d3 - d2s) / ((d1 - d3) * d2);
  const double sin_phis[4] = {sin_phi, -sin_phi, -sin_phi, sin_phi};
  for (int i = 0; i < 4; ++i) {
    Eigen::Matrix3d Rp;
    Rp << cos_phi, 0, sin_phis[i], 0, -1, 0, sin_phis[i], 0, -cos_phi;
    candidates.emplace_back(s * U * Rp * V.transpose(), V * Eigen::Vector3d(x1[i], 0, x3[i]));
  }

  // For each (R, n), recover the scale lambda of H and t/d from lambda H = R + (t/d) n^T:
  // on the plane orthogonal to n, lambda H m = R m; along n, t/d = (lambda H - R) n.
  for (auto& [R, n_raw] : candidates) {
    // No sign normalization of n: (R, t, n) and (R, -t, -n) explain the same H but are
    // different motions, of which only one puts the points in front; the caller tells them
    // apart by triangulating (ORB-SLAM's CheckRT).
    const Eigen::Vector3d n = n_raw.normalized();
    const Eigen::Vector3d helper =
        std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    const Eigen::Vector3d m1 = n.cross(helper).normalized();
    const Eigen::Vector3d m2 = n.cross(m1);
    const Eigen::Vector3d Hm1 = H * m1, Hm2 = H * m2;
    const double denominator = Hm1.squaredNorm() + Hm2.squaredNorm();
    if (!(denominator > 0.0)) continue;
    const double lambda = ((R * m1).dot(Hm1) + (R * m2).dot(Hm2)) / denominator;
    HomographyMotion motion;
    motion.R = R;
    motion.n = n;
    motion.t = (lambda * H - R) * n;
    if (motion.R.allFinite() && motion.t.allFinite()) motions->push_back(motion);
  }
  return static_cast<int>(motions->size());
}

void HomographyEstimator::Estimate(const std::vector<int>& sample,
                                   std::vector<Model>* models) const {
  models->clear();
  Eigen::Matrix3d H;
  if (Dlt(points1_, points2_, count_, &sample, &H)) models->push_back(H);
}

void HomographyEstimator::Residuals(const Model& H, std::vector<double>* squared_residuals) const {
  squared_residuals->resize(count_);
  const Eigen::Matrix3d H_inverse = H.inverse();
  for (int i = 0; i < count_; ++i) {
    (*squared_residuals)[i] = SquaredSymmetricTransferError(H, H_inverse, points1_[i], points2_[i]);
  }
}

bool HomographyEstimator::Refine(const std::vector<int>& inliers, Model* H) const {
  Eigen::Matrix3d refined;
  if (!Dlt(points1_, points2_, count_, &inliers, &refined)) return false;
  *H = refined;
  return true;
}

}  // namespace lcv::slam
