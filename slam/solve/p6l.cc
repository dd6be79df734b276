#include "slam/solve/p6l.h"

#include <algorithm>
#include <cmath>
#include <exception>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <opengv/relative_pose/NoncentralRelativeAdapter.hpp>
#include <opengv/relative_pose/methods.hpp>

namespace lcv::slam {
namespace {

constexpr double kBehindCamera = 4.0;  // squared residual of an impossible correspondence

// Nearest rotation (Frobenius) to a 3x3 matrix; OpenGV's rotations are orthonormal only up to
// the Groebner solver's round-off.
Eigen::Matrix3d NearestRotation(const Eigen::Matrix3d& m) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  return svd.matrixU() * d * svd.matrixV().transpose();
}

// Translation for a given world_from_cam rotation: null vector of G (header eq. 1), from the
// eigenvector of the smallest eigenvalue (SelfAdjointEigenSolver sorts them ascending). False
// when the homogeneous coordinate vanishes (translation at infinity: degenerate lines).
bool TranslationForRotation(const Eigen::Matrix3d& world_R_cam, const Eigen::Vector3d* bearings,
                            const Line3d* lines, int count, Eigen::Vector3d* world_t_cam) {
  Eigen::Matrix4d G = Eigen::Matrix4d::Zero();
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d ray = world_R_cam * bearings[i];
    Eigen::Vector4d g;
    g.head<3>() = lines[i].direction.cross(ray);
    g[3] = lines[i].direction.dot(lines[i].anchor.cross(ray));
    G += g * g.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eigen(G);
  if (eigen.info() != Eigen::Success) return false;
  const Eigen::Vector4d v = eigen.eigenvectors().col(0);
  if (!(std::abs(v[3]) > 1e-12 * v.head<3>().norm())) return false;
  *world_t_cam = v.head<3>() / v[3];
  return world_t_cam->allFinite();
}

}  // namespace

bool BearingPlaneResidual(const Rigid3d& cam_from_world, const Eigen::Vector3d& bearing,
                          const Line3d& world_line, double* residual,
                          Eigen::Matrix<double, 1, 6>* jacobian) {
  const Eigen::Vector3d a = cam_from_world * world_line.anchor;
  const Eigen::Vector3d d = cam_from_world.rotation * world_line.direction;
  const Eigen::Vector3d n = a.cross(d);
  const double n_norm = n.norm();
  if (!(n_norm > 1e-12 * std::max(1.0, a.norm()))) return false;
  const Eigen::Vector3d n_hat = n / n_norm;
  *residual = bearing.dot(n_hat);
  if (jacobian) {
    // Left perturbation: a' = a + w x a + v, d' = d + w x d, so n' = n + w x n + v x d.
    // r = b . n/|n|: dr/dw = (n_hat x b)^T, dr/dv = -((P b) x d)^T / |n|, P = I - n_hat n_hat^T.
    const Eigen::Vector3d projected_bearing = bearing - n_hat * n_hat.dot(bearing);
    jacobian->leftCols<3>() = -(projected_bearing.cross(d) / n_norm).transpose();
    jacobian->rightCols<3>() = n_hat.cross(bearing).transpose();
  }
  return true;
}

double SquaredBearingPlaneError(const Rigid3d& cam_from_world, const Eigen::Vector3d& bearing,
                                const Line3d& world_line) {
  double r = 0.0;
  if (!BearingPlaneResidual(cam_from_world, bearing, world_line, &r, nullptr)) return kBehindCamera;
  // Depth of the ray's closest approach to the line: behind the camera means the bearing cannot
  // be an image of any point of the line.
  const Line3d line_in_cam(cam_from_world * world_line.anchor,
                           cam_from_world.rotation * world_line.direction);
  const auto closest = ClosestPointsBetweenLines(Line3d(Eigen::Vector3d::Zero(), bearing),
                                                 line_in_cam, 1e-9);
  if (closest && closest->s_a <= 0.0) return kBehindCamera;
  return r * r;
}

int SolveP6L(const Eigen::Vector3d* bearings, const Line3d* world_lines, int count,
             std::vector<Rigid3d>* cam_from_world) {
  cam_from_world->clear();
  if (count < 6) return 0;
  constexpr int kN = 6;
  // Condition the polynomial system: lines in a frame centred on their anchors, unit RMS spread.
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (int i = 0; i < kN; ++i) centre += world_lines[i].anchor;
  centre /= kN;
  double spread = 0.0;
  for (int i = 0; i < kN; ++i) spread += (world_lines[i].anchor - centre).squaredNorm();
  spread = std::sqrt(spread / kN);
  if (!(spread > 0.0) || !std::isfinite(spread)) spread = 1.0;

  opengv::bearingVectors_t line_directions, camera_bearings;
  opengv::translations_t offsets;
  opengv::rotations_t offset_rotations;
  std::vector<int> cameras_1, cameras_2;
  Line3d normalized[kN];
  for (int i = 0; i < kN; ++i) {
    if (!bearings[i].allFinite() || !world_lines[i].anchor.allFinite() ||
        !world_lines[i].direction.allFinite()) {
      return 0;
    }
    normalized[i] = Line3d((world_lines[i].anchor - centre) / spread,
                           world_lines[i].direction.normalized());
    line_directions.push_back(normalized[i].direction);
    camera_bearings.push_back(bearings[i].normalized());
    offsets.push_back(normalized[i].anchor);
    offset_rotations.push_back(Eigen::Matrix3d::Identity());
    cameras_1.push_back(i);
    cameras_2.push_back(kN);  // the query: one central camera at the body origin
  }
  offsets.push_back(Eigen::Vector3d::Zero());
  offset_rotations.push_back(Eigen::Matrix3d::Identity());
  // Viewpoint 1 = the (normalized) world with one camera per line, viewpoint 2 = the query camera;
  // sixpt returns R12 = world_R_cam.
  const opengv::relative_pose::NoncentralRelativeAdapter adapter(
      line_directions, camera_bearings, cameras_1, cameras_2, offsets, offset_rotations);
  opengv::rotations_t rotations;
  try {
    rotations = opengv::relative_pose::sixpt(adapter);
  } catch (const std::exception&) {
    return 0;  // OpenGV signals some degenerate inputs by throwing
  }

  Eigen::Vector3d unit_bearings[kN];
  for (int i = 0; i < kN; ++i) unit_bearings[i] = camera_bearings[i];
  for (const Eigen::Matrix3d& raw : rotations) {
    if (!raw.allFinite()) continue;
    const Eigen::Matrix3d world_R_cam = NearestRotation(raw);
    Eigen::Vector3d t_normalized;
    if (!TranslationForRotation(world_R_cam, unit_bearings, normalized, kN, &t_normalized)) {
      continue;
    }
    // Undo the normalization: x_world = centre + spread * (R x_cam / spread + t_normalized).
    Eigen::Quaterniond q(world_R_cam);
    q.normalize();
    const Rigid3d world_from_cam(q, centre + spread * t_normalized);
    Rigid3d candidate = world_from_cam.Inverse();
    // The Groebner solver is accurate to only ~1e-3..1e-7 (elimination template round-off):
    // polish with Gauss-Newton on the six equations themselves (quadratic convergence).
    P6LRefinementOptions polish;
    polish.max_iterations = 4;
    RefineP6L(unit_bearings, world_lines, kN, nullptr, polish, &candidate);
    bool in_front = true;
    for (int i = 0; i < kN && in_front; ++i) {
      in_front = SquaredBearingPlaneError(candidate, unit_bearings[i], world_lines[i]) <
                 kBehindCamera;
    }
    if (!in_front) continue;
    // Distinct solutions only (the Groebner basis may repeat a real root).
    bool duplicate = false;
    for (const Rigid3d& kept : *cam_from_world) {
      duplicate |= kept.rotation.angularDistance(candidate.rotation) < 1e-9 &&
                   (kept.translation - candidate.translation).norm() < 1e-9 * spread;
    }
    if (!duplicate) cam_from_world->push_back(candidate);
  }
  return static_cast<int>(cam_from_world->size());
}

int RefineP6L(const Eigen::Vector3d* bearings, const Line3d* world_lines, int count,
              const std::vector<int>* indices, const P6LRefinementOptions& options,
              Rigid3d* cam_from_world, double* final_cost) {
  std::vector<int> active;
  const int n = indices ? static_cast<int>(indices->size()) : count;
  for (int k = 0; k < n; ++k) {
    const int i = indices ? (*indices)[k] : k;
    if (SquaredBearingPlaneError(*cam_from_world, bearings[i], world_lines[i]) < kBehindCamera) {
      active.push_back(i);
    }
  }
  if (active.size() < 6) return -1;
  const double huber = options.huber_threshold_rad;
  // Robust cost and the IRLS weight of one residual.
  auto rho = [huber](double r2, double* weight) {
    if (huber <= 0.0 || r2 <= huber * huber) {
      if (weight) *weight = 1.0;
      return r2;
    }
    const double r = std::sqrt(r2);
    if (weight) *weight = huber / r;
    return 2.0 * huber * r - huber * huber;
  };
  auto cost_at = [&](const Rigid3d& pose) {
    double cost = 0.0;
    for (const int i : active) {
      double r = 0.0;
      if (!BearingPlaneResidual(pose, bearings[i], world_lines[i], &r, nullptr)) return HUGE_VAL;
      cost += rho(r * r, nullptr);
    }
    return cost;
  };

  Rigid3d pose = *cam_from_world;
  double cost = cost_at(pose);
  int iteration = 0;
  for (; iteration < options.max_iterations; ++iteration) {
    Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
    Vector6d g = Vector6d::Zero();
    for (const int i : active) {
      double r = 0.0;
      Eigen::Matrix<double, 1, 6> J;
      if (!BearingPlaneResidual(pose, bearings[i], world_lines[i], &r, &J)) continue;
      double w = 1.0;
      rho(r * r, &w);
      H += w * J.transpose() * J;
      g += w * J.transpose() * r;
    }
    const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(H);
    if (ldlt.info() != Eigen::Success || !ldlt.isPositive() ||
        ldlt.vectorD().minCoeff() <= 1e-14 * std::max(1.0, ldlt.vectorD().maxCoeff())) {
      if (iteration == 0) return -1;
      break;
    }
    Vector6d delta = -ldlt.solve(g);
    if (!delta.allFinite()) break;
    bool improved = false;
    for (int halving = 0; halving < 8; ++halving) {
      const Rigid3d candidate = Rigid3d::Exp(delta) * pose;
      const double candidate_cost = cost_at(candidate);
      if (candidate_cost <= cost) {
        pose = candidate;
        cost = candidate_cost;
        improved = true;
        break;
      }
      delta *= 0.5;
    }
    if (!improved || delta.norm() < options.min_step) {
      ++iteration;
      break;
    }
  }
  pose.rotation.normalize();
  *cam_from_world = pose;
  if (final_cost) {
    double sum = 0.0;
    for (const int i : active) {
      double r = 0.0;
      if (BearingPlaneResidual(pose, bearings[i], world_lines[i], &r, nullptr)) sum += r * r;
    }
    *final_cost = sum;
  }
  return iteration;
}

void P6LEstimator::Estimate(const std::vector<int>& sample, std::vector<Model>* models) const {
  Eigen::Vector3d b[6];
  Line3d l[6];
  for (int k = 0; k < 6; ++k) {
    b[k] = bearings_[sample[k]];
    l[k] = lines_[sample[k]];
  }
  SolveP6L(b, l, 6, models);
}

void P6LEstimator::Residuals(const Model& cam_from_world,
                             std::vector<double>* squared_residuals) const {
  squared_residuals->resize(count_);
  for (int i = 0; i < count_; ++i) {
    (*squared_residuals)[i] = SquaredBearingPlaneError(cam_from_world, bearings_[i], lines_[i]);
  }
}

bool P6LEstimator::Refine(const std::vector<int>& inliers, Model* cam_from_world) const {
  P6LRefinementOptions options;
  options.max_iterations = 5;
  return RefineP6L(bearings_, lines_, count_, &inliers, options, cam_from_world) >= 0;
}

P6LResult EstimateP6L(const std::vector<Eigen::Vector3d>& bearings,
                      const std::vector<Line3d>& world_lines, const P6LOptions& options) {
  LCV_CHECK(bearings.size() == world_lines.size()) << "bearings and lines differ in count";
  P6LResult result;
  RansacOptions ransac = options.ransac;
  if (!(ransac.max_error > 0.0)) ransac.max_error = options.max_angular_error_rad;
  const P6LEstimator estimator(bearings.data(), world_lines.data(),
                               static_cast<int>(bearings.size()));
  return RefineLineCloudPose(Ransac(ransac, estimator), bearings, world_lines, options,
                             ransac.max_error);
}

P6LResult RefineLineCloudPose(const RansacReport<Rigid3d>& report,
                              const std::vector<Eigen::Vector3d>& bearings,
                              const std::vector<Line3d>& world_lines, const P6LOptions& options,
                              double max_error) {
  LCV_CHECK(bearings.size() == world_lines.size()) << "bearings and lines differ in count";
  P6LResult result;
  result.num_trials = report.num_trials;
  result.stopped_early = report.stopped_early;
  if (!report.success) return result;
  Rigid3d pose = report.model;
  std::vector<char> mask = report.inlier_mask;
  if (options.refine) {
    std::vector<int> inliers;
    for (int i = 0; i < static_cast<int>(mask.size()); ++i) {
      if (mask[i]) inliers.push_back(i);
    }
    if (RefineP6L(bearings.data(), world_lines.data(), static_cast<int>(bearings.size()),
                  &inliers, options.refinement, &pose) >= 0) {
      const double max_sq = max_error * max_error;
      for (size_t i = 0; i < bearings.size(); ++i) {
        mask[i] = SquaredBearingPlaneError(pose, bearings[i], world_lines[i]) <= max_sq;
      }
    } else {
      pose = report.model;
    }
  }
  result.num_inliers = static_cast<int>(std::count(mask.begin(), mask.end(), 1));
  result.cam_from_world = pose;
  result.inlier_mask = std::move(mask);
  result.success = result.num_inliers >= options.min_num_inliers &&
                   result.num_inliers >= options.ransac.min_inlier_ratio * bearings.size();
  return result;
}

}  // namespace lcv::slam
