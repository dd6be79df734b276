#include "slam/optimize/sim3_reprojection.h"

#include <cmath>
#include <limits>

#include <Eigen/Cholesky>

#include "slam/geometry/so3.h"
#include "slam/solve/umeyama.h"

namespace lcv::slam {

bool Sim3ReprojectionResidual(const Camera& camera_a, const Camera& camera_b,
                              const Sim3Correspondence& c, const Sim3d& a_from_b,
                              Eigen::Vector4d* residual,
                              Eigen::Matrix<double, 4, 7>* J_residual_delta) {
  const Eigen::Vector3d y = a_from_b * c.point_in_b;
  const Sim3d b_from_a = a_from_b.Inverse();
  const Eigen::Vector3d z = b_from_a * c.point_in_a;
  Eigen::Matrix<double, 2, 3> J_pxa_y, J_pxb_z;
  const bool want_jacobian = J_residual_delta != nullptr;
  const std::optional<Eigen::Vector2d> px_a =
      camera_a.Project(y, want_jacobian ? &J_pxa_y : nullptr);
  const std::optional<Eigen::Vector2d> px_b =
      camera_b.Project(z, want_jacobian ? &J_pxb_z : nullptr);
  if (!px_a || !px_b) return false;
  residual->head<2>() = *px_a - c.px_a;
  residual->tail<2>() = *px_b - c.px_b;
  if (want_jacobian) {
    // y(delta) = Exp(delta) S X_b ~ y + v + omega x y + sigma y.
    Eigen::Matrix<double, 3, 7> J_y_delta;
    J_y_delta << Eigen::Matrix3d::Identity(), -SkewSymmetric(y), y;
    // z(delta) = S^-1 Exp(-delta) X_a ~ z + (1/s) R^T (-v - omega x X_a - sigma X_a).
    Eigen::Matrix<double, 3, 7> J_inner;
    J_inner << -Eigen::Matrix3d::Identity(), SkewSymmetric(c.point_in_a), -c.point_in_a;
    const Eigen::Matrix3d linear_b_from_a =
        b_from_a.scale * b_from_a.rotation.toRotationMatrix();
    J_residual_delta->topRows<2>() = J_pxa_y * J_y_delta;
    J_residual_delta->bottomRows<2>() = J_pxb_z * linear_b_from_a * J_inner;
  }
  return true;
}

double Sim3ReprojectionChi2(const Camera& camera_a, const Camera& camera_b,
                            const Sim3Correspondence& c, const Sim3d& a_from_b) {
  Eigen::Vector4d r;
  if (!Sim3ReprojectionResidual(camera_a, camera_b, c, a_from_b, &r)) {
    return std::numeric_limits<double>::infinity();
  }
  return std::max(c.information_a * r.head<2>().squaredNorm(),
                  c.information_b * r.tail<2>().squaredNorm());
}

Sim3ReprojectionEstimator::Sim3ReprojectionEstimator(
    const Camera& camera_a, const Camera& camera_b,
    const std::vector<Sim3Correspondence>& correspondences)
    : camera_a_(camera_a), camera_b_(camera_b), correspondences_(correspondences) {
  points_a_.reserve(correspondences.size());
  points_b_.reserve(correspondences.size());
  for (const Sim3Correspondence& c : correspondences) {
    points_a_.push_back(c.point_in_a);
    points_b_.push_back(c.point_in_b);
  }
}

void Sim3ReprojectionEstimator::Estimate(const std::vector<int>& sample,
                                         std::vector<Model>* models) const {
  models->clear();
  Eigen::Vector3d src[kMinNumSamples], dst[kMinNumSamples];
  for (int k = 0; k < kMinNumSamples; ++k) {
    src[k] = points_b_[sample[k]];
    dst[k] = points_a_[sample[k]];
  }
  Sim3d a_from_b;
  if (AlignUmeyama(src, dst, kMinNumSamples, true, &a_from_b)) models->push_back(a_from_b);
}

void Sim3ReprojectionEstimator::Residuals(const Model& a_from_b,
                                          std::vector<double>* squared_residuals) const {
  squared_residuals->resize(correspondences_.size());
  for (size_t i = 0; i < correspondences_.size(); ++i) {
    (*squared_residuals)[i] =
        Sim3ReprojectionChi2(camera_a_, camera_b_, correspondences_[i], a_from_b);
  }
}

bool Sim3ReprojectionEstimator::Refine(const std::vector<int>& inliers, Model* a_from_b) const {
  std::vector<Eigen::Vector3d> src, dst;
  src.reserve(inliers.size());
  dst.reserve(inliers.size());
  for (const int i : inliers) {
    src.push_back(points_b_[i]);
    dst.push_back(points_a_[i]);
  }
  return AlignUmeyama(src, dst, true, a_from_b);
}

namespace {

// Robust cost of the correspondences in `active` and, when H and g are given, the Gauss-Newton
// system (Huber weights, whitened by the information of each side).
double BuildSystem(const Camera& camera_a, const Camera& camera_b,
                   const std::vector<Sim3Correspondence>& correspondences,
                   const std::vector<char>& active, double huber_sq, const Sim3d& a_from_b,
                   Eigen::Matrix<double, 7, 7>* H, Eigen::Matrix<double, 7, 1>* g) {
  double cost = 0.0;
  if (H != nullptr) {
    H->setZero();
    g->setZero();
  }
  const double huber = std::sqrt(huber_sq);
  Eigen::Vector4d r;
  Eigen::Matrix<double, 4, 7> J;
  for (size_t i = 0; i < correspondences.size(); ++i) {
    if (!active[i]) continue;
    const Sim3Correspondence& c = correspondences[i];
    if (!Sim3ReprojectionResidual(camera_a, camera_b, c, a_from_b, &r, H ? &J : nullptr)) {
      cost += 2.0 * huber_sq;  // a point that left the image costs like a far outlier
      continue;
    }
    for (int side = 0; side < 2; ++side) {
      const double information = side == 0 ? c.information_a : c.information_b;
      const double e2 = information * r.segment<2>(2 * side).squaredNorm();
      const double e = std::sqrt(e2);
      // Huber: rho(e2) = e2 inside, 2 huber e - huber^2 outside; weight = rho'(e2).
      const double weight = e <= huber ? 1.0 : huber / e;
      cost += e <= huber ? e2 : 2.0 * huber * e - huber_sq;
      if (H != nullptr) {
        const Eigen::Matrix<double, 2, 7> Js = J.middleRows<2>(2 * side);
        *H += weight * information * Js.transpose() * Js;
        *g += weight * information * Js.transpose() * r.segment<2>(2 * side);
      }
    }
  }
  return cost;
}

void GaussNewtonPass(const Camera& camera_a, const Camera& camera_b,
                     const std::vector<Sim3Correspondence>& correspondences,
                     const std::vector<char>& active, double huber_sq, int iterations,
                     Sim3d* a_from_b) {
  Eigen::Matrix<double, 7, 7> H;
  Eigen::Matrix<double, 7, 1> g;
  double lambda = 1e-6;
  double cost =
      BuildSystem(camera_a, camera_b, correspondences, active, huber_sq, *a_from_b, &H, &g);
  for (int it = 0; it < iterations; ++it) {
    bool improved = false;
    for (int attempt = 0; attempt < 6 && !improved; ++attempt) {
      Eigen::Matrix<double, 7, 7> damped = H;
      damped.diagonal() += lambda * (H.diagonal().array() + 1e-9).matrix();
      const Eigen::Matrix<double, 7, 1> delta = damped.ldlt().solve(-g);
      if (!delta.allFinite()) break;
      const Sim3d candidate = Sim3d::Exp(delta) * *a_from_b;
      const double candidate_cost = BuildSystem(camera_a, camera_b, correspondences, active,
                                                huber_sq, candidate, nullptr, nullptr);
      if (candidate_cost < cost) {
        *a_from_b = candidate;
        a_from_b->rotation.normalize();
        lambda = std::max(1e-9, lambda * 0.1);
        improved = true;
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved) break;
    cost = BuildSystem(camera_a, camera_b, correspondences, active, huber_sq, *a_from_b, &H, &g);
  }
}

}  // namespace

Sim3RefineReport RefineSim3Reprojection(const Camera& camera_a, const Camera& camera_b,
                                        const std::vector<Sim3Correspondence>& correspondences,
                                        const Sim3RefineOptions& options, Sim3d* a_from_b) {
  const int n = static_cast<int>(correspondences.size());
  std::vector<char> active(n, 1);
  GaussNewtonPass(camera_a, camera_b, correspondences, active, options.chi2_threshold,
                  options.iterations, a_from_b);
  for (int i = 0; i < n; ++i) {
    active[i] = Sim3ReprojectionChi2(camera_a, camera_b, correspondences[i], *a_from_b) <=
                options.chi2_threshold;
  }
  GaussNewtonPass(camera_a, camera_b, correspondences, active, options.chi2_threshold,
                  options.iterations, a_from_b);
  Sim3RefineReport report;
  report.inlier_mask.assign(n, 0);
  for (int i = 0; i < n; ++i) {
    if (Sim3ReprojectionChi2(camera_a, camera_b, correspondences[i], *a_from_b) <=
        options.chi2_threshold) {
      report.inlier_mask[i] = 1;
      ++report.num_inliers;
    }
  }
  return report;
}

}  // namespace lcv::slam
