#include "slam/optimize/motion_only_ba.h"

#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "slam/optimize/residuals.h"
#include "slam/util/error.h"

namespace lcv::slam {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

// Huber on a chi^2 value s with threshold delta^2: rho(s) = s below, 2 delta sqrt(s) - delta^2
// above (Ceres' HuberLoss). The IRLS weight is rho'(s).
struct Robust {
  double rho;
  double weight;
};
inline Robust Huber(double chi2, double delta2, bool robust) {
  if (!robust || chi2 <= delta2) return {chi2, 1.0};
  const double delta = std::sqrt(delta2);
  const double root = std::sqrt(chi2);
  return {2.0 * delta * root - delta2, delta / root};
}

// Inverse of a 3x3 block that may be near singular (a viewing ray parallel to its line):
// false when the determinant is negligible against the block's scale.
inline bool InvertBlock(const Eigen::Matrix3d& H, Eigen::Matrix3d* H_inv) {
  const double scale = H.diagonal().cwiseAbs().maxCoeff();
  const double det = H.determinant();
  if (!(scale > 0.0) || !(std::abs(det) > 1e-14 * scale * scale * scale)) return false;
  *H_inv = H.inverse();
  return true;
}

}  // namespace

namespace internal {

double PointTermChi2(const Camera& camera, const Rigid3d& cam_from_world,
                     const MotionOnlyPointTerm& term) {
  Eigen::Vector2d r;
  if (!ReprojectionResidual(camera, cam_from_world, term.p_in_world, term.observed_px, &r)) {
    return std::numeric_limits<double>::infinity();
  }
  return term.information * r.squaredNorm();
}

double LineTermChi2(const Camera& camera, const Rigid3d& cam_from_world,
                    const MotionOnlyLineTerm& term, const Eigen::Matrix3d& line_jacobian,
                    double line_weight) {
  Eigen::Vector2d r;
  if (!ReprojectionResidual(camera, cam_from_world, term.restored_point, term.observed_px,
                            &r)) {
    return std::numeric_limits<double>::infinity();
  }
  const Eigen::Vector3d r_line = line_jacobian * (term.restored_point - term.line.anchor);
  return term.information * r.squaredNorm() + line_weight * r_line.squaredNorm();
}

void RefitRestoredPoint(const Camera& camera, const Rigid3d& cam_from_world,
                        const Eigen::Matrix3d& line_jacobian, double line_weight,
                        MotionOnlyLineTerm* term) {
  const Eigen::Matrix3d& A = line_jacobian;
  Eigen::Vector2d r;
  Matrix23d J_point;
  for (int step = 0; step < 3; ++step) {
    if (!ReprojectionResidual(camera, cam_from_world, term->restored_point, term->observed_px,
                              &r, nullptr, &J_point)) {
      return;
    }
    const Eigen::Vector3d r_line = A * (term->restored_point - term->line.anchor);
    Eigen::Matrix3d H =
        term->information * J_point.transpose() * J_point + line_weight * A.transpose() * A;
    const Eigen::Vector3d g =
        term->information * J_point.transpose() * r + line_weight * A.transpose() * r_line;
    H.diagonal().array() += 1e-9 * (1.0 + H.diagonal().maxCoeff());
    Eigen::Matrix3d H_inv;
    if (!InvertBlock(H, &H_inv)) return;
    const Eigen::Vector3d step_x = -H_inv * g;
    // Keep the step only if the point stays imageable.
    Eigen::Vector2d r_new;
    if (!ReprojectionResidual(camera, cam_from_world, term->restored_point + step_x,
                              term->observed_px, &r_new)) {
      return;
    }
    term->restored_point += step_x;
  }
}

}  // namespace internal

Eigen::Vector3d InitialRestoredPoint(const Rigid3d& cam_from_world,
                                     const Eigen::Vector3d& bearing_in_cam, const Line3d& line) {
  const Eigen::Vector3d center = cam_from_world.Center();
  const Line3d ray(center, cam_from_world.rotation.conjugate() * bearing_in_cam.normalized());
  const std::optional<ClosestPoints> closest = ClosestPointsBetweenLines(ray, line, 1e-6);
  if (!closest || closest->s_a <= 0.0) return line.Project(center);
  return 0.5 * (ray.PointAt(closest->s_a) + line.PointAt(closest->s_b));
}

std::string MotionOnlyBAOptions::Problem() const {
  std::ostringstream out;
  if (num_rounds < 1) out << "num_rounds must be >= 1 (is " << num_rounds << ")";
  else if (iterations_per_round < 1) out << "iterations_per_round must be >= 1";
  else if (robust_rounds < 0) out << "robust_rounds must be >= 0";
  else if (!(point_chi2_threshold > 0.0)) out << "point_chi2_threshold must be > 0";
  else if (!(line_chi2_threshold > 0.0)) out << "line_chi2_threshold must be > 0";
  else if (!(line_weight >= 0.0)) out << "line_weight must be >= 0";
  else if (!(initial_lambda >= 0.0)) out << "initial_lambda must be >= 0";
  else if (!(min_step_norm >= 0.0)) out << "min_step_norm must be >= 0";
  else if (!(function_tolerance >= 0.0)) out << "function_tolerance must be >= 0";
  return out.str();
}

MotionOnlyBA::MotionOnlyBA(const MotionOnlyBAOptions& options) : options_(options) {
  const std::string problem = options_.Problem();
  LCV_CHECK(problem.empty()) << problem;
}

bool MotionOnlyBA::Linearize(const Camera& camera, const Rigid3d& cam_from_world,
                             const std::vector<MotionOnlyPointTerm>& points,
                             const std::vector<MotionOnlyLineTerm>& lines,
                             const std::vector<Eigen::Vector3d>& restored_points, bool robust,
                             Linearization* out) const {
  out->H_pose_pose.setZero();
  out->g_pose.setZero();
  out->cost = 0.0;
  Eigen::Vector2d r;
  Matrix26d J_pose;
  Matrix23d J_point;
  for (const MotionOnlyPointTerm& term : points) {
    if (!term.inlier) continue;
    if (!ReprojectionResidual(camera, cam_from_world, term.p_in_world, term.observed_px, &r,
                              &J_pose)) {
      return false;
    }
    const Robust k = Huber(term.information * r.squaredNorm(), options_.point_chi2_threshold,
                           robust);
    const double w = k.weight * term.information;
    out->H_pose_pose.noalias() += w * J_pose.transpose() * J_pose;
    out->g_pose.noalias() += w * J_pose.transpose() * r;
    out->cost += 0.5 * k.rho;
  }
  const double line_weight = options_.line_weight;
  for (size_t i = 0; i < lines.size(); ++i) {
    const MotionOnlyLineTerm& term = lines[i];
    if (!term.inlier) continue;
    const Eigen::Vector3d& x = restored_points[i];
    if (!ReprojectionResidual(camera, cam_from_world, x, term.observed_px, &r, &J_pose,
                              &J_point)) {
      return false;
    }
    const Eigen::Matrix3d& A = line_jacobians_[i];
    const Eigen::Vector3d r_line = A * (x - term.line.anchor);
    const double chi2 = term.information * r.squaredNorm() + line_weight * r_line.squaredNorm();
    const Robust k = Huber(chi2, options_.line_chi2_threshold, robust);
    const double w = k.weight * term.information;
    const double w_line = k.weight * line_weight;
    LineBlock& block = out->lines[i];
    out->H_pose_pose.noalias() += w * J_pose.transpose() * J_pose;
    out->g_pose.noalias() += w * J_pose.transpose() * r;
    block.H_pose_point.noalias() = w * J_pose.transpose() * J_point;
    block.H_point_point.noalias() = w * J_point.transpose() * J_point;
    block.H_point_point.noalias() += w_line * A.transpose() * A;
    block.g_point.noalias() = w * J_point.transpose() * r;
    block.g_point.noalias() += w_line * A.transpose() * r_line;
    out->cost += 0.5 * k.rho;
  }
  return true;
}

bool MotionOnlyBA::RunLevenbergMarquardt(const Camera& camera, bool robust,
                                         Rigid3d* cam_from_world,
                                         const std::vector<MotionOnlyPointTerm>& points,
                                         std::vector<MotionOnlyLineTerm>* lines,
                                         int* num_iterations) {
  const size_t num_lines = lines->size();
  for (size_t i = 0; i < num_lines; ++i) current_points_[i] = (*lines)[i].restored_point;
  if (!Linearize(camera, *cam_from_world, points, *lines, current_points_, robust, &current_)) {
    return false;  // the caller classified unprojectable terms out before; cannot happen
  }
  // Reduced (Schur) system S dp = -g_s of the damped normal equations; the inverted X' blocks
  // are kept in candidate_.lines[i].H_point_point for the back-substitution.
  Matrix6d S;
  Eigen::Matrix<double, 6, 1> g_s;
  auto reduce = [&](double lambda) {
    S = current_.H_pose_pose;
    S.diagonal() += lambda * current_.H_pose_pose.diagonal();
    g_s = current_.g_pose;
    for (size_t i = 0; i < num_lines; ++i) {
      if (!(*lines)[i].inlier) continue;
      const LineBlock& block = current_.lines[i];
      Eigen::Matrix3d H_kk = block.H_point_point;
      H_kk.diagonal() += lambda * block.H_point_point.diagonal();
      // A ray parallel to its line leaves the X' block singular; a tiny ridge keeps the
      // elimination defined (X' then moves along the line only as far as the ridge allows).
      Eigen::Matrix3d H_kk_inv;
      if (!InvertBlock(H_kk, &H_kk_inv)) {
        H_kk.diagonal().array() += 1e-9 * (1.0 + H_kk.diagonal().maxCoeff());
        if (!InvertBlock(H_kk, &H_kk_inv)) return false;
      }
      candidate_.lines[i].H_point_point = H_kk_inv;
      const Eigen::Matrix<double, 6, 3> HpkHkkinv = block.H_pose_point * H_kk_inv;
      S.noalias() -= HpkHkkinv * block.H_pose_point.transpose();
      g_s.noalias() -= HpkHkkinv * block.g_point;
    }
    return true;
  };
  auto full_rank = [](const Eigen::LDLT<Matrix6d>& ldlt) {
    const Eigen::Matrix<double, 6, 1> D = ldlt.vectorD();
    return ldlt.info() == Eigen::Success && D.minCoeff() > 1e-10 * D.cwiseAbs().maxCoeff();
  };
  // The damping below would make any system invertible: whether the active terms determine
  // the pose is decided on the undamped reduced system.
  if (!reduce(0.0) || !full_rank(Eigen::LDLT<Matrix6d>(S))) return false;

  double lambda = options_.initial_lambda;
  bool solved_once = false;
  for (int iteration = 0; iteration < options_.iterations_per_round; ++iteration) {
    ++*num_iterations;
    if (!reduce(lambda)) return solved_once;
    const Eigen::LDLT<Matrix6d> ldlt(S);
    if (!full_rank(ldlt)) return solved_once;
    solved_once = true;
    const Vector6d dp = ldlt.solve(-g_s);
    const Rigid3d candidate_pose = Rigid3d::Exp(dp) * *cam_from_world;
    for (size_t i = 0; i < num_lines; ++i) {
      if (!(*lines)[i].inlier) {
        candidate_points_[i] = current_points_[i];
        continue;
      }
      const LineBlock& block = current_.lines[i];
      const Eigen::Vector3d dk = candidate_.lines[i].H_point_point *
                                 (-block.g_point - block.H_pose_point.transpose() * dp);
      candidate_points_[i] = current_points_[i] + dk;
    }
    const bool valid = Linearize(camera, candidate_pose, points, *lines, candidate_points_,
                                 robust, &candidate_);
    if (valid && candidate_.cost <= current_.cost) {
      const double decrease = current_.cost - candidate_.cost;
      *cam_from_world = candidate_pose;
      std::swap(current_, candidate_);
      std::swap(current_points_, candidate_points_);
      lambda = std::max(lambda * 0.1, 1e-12);
      if (dp.norm() < options_.min_step_norm ||
          decrease <= options_.function_tolerance * current_.cost) {
        break;
      }
    } else {
      lambda = std::max(lambda * 10.0, 1e-6);
      if (lambda > 1e8) break;  // no descent possible: at a minimum up to rounding
    }
  }
  for (size_t i = 0; i < num_lines; ++i) {
    if ((*lines)[i].inlier) (*lines)[i].restored_point = current_points_[i];
  }
  return solved_once;
}

MotionOnlyBAReport MotionOnlyBA::Solve(const Camera& camera, Rigid3d* cam_from_world,
                                       std::vector<MotionOnlyPointTerm>* points,
                                       std::vector<MotionOnlyLineTerm>* lines) {
  LCV_CHECK(cam_from_world != nullptr && points != nullptr && lines != nullptr);
  const size_t num_lines = lines->size();
  current_.lines.resize(num_lines);
  candidate_.lines.resize(num_lines);
  line_jacobians_.resize(num_lines);
  current_points_.resize(num_lines);
  candidate_points_.resize(num_lines);
  for (size_t i = 0; i < num_lines; ++i) {
    const Line3d& line = (*lines)[i].line;
    line_jacobians_[i] =
        (*lines)[i].sqrt_information *
        (Eigen::Matrix3d::Identity() - line.direction * line.direction.transpose());
  }
  const double line_weight = options_.line_weight;
  auto point_chi2 = [&](const MotionOnlyPointTerm& term) {
    return internal::PointTermChi2(camera, *cam_from_world, term);
  };
  auto line_chi2 = [&](size_t i, bool refit) {
    if (refit) {
      internal::RefitRestoredPoint(camera, *cam_from_world, line_jacobians_[i], line_weight,
                                   &(*lines)[i]);
    }
    return internal::LineTermChi2(camera, *cam_from_world, (*lines)[i], line_jacobians_[i],
                                  line_weight);
  };
  auto total_cost = [&]() {
    double cost = 0.0;
    for (const MotionOnlyPointTerm& term : *points) {
      if (term.inlier) cost += 0.5 * term.chi2;
    }
    for (const MotionOnlyLineTerm& term : *lines) {
      if (term.inlier) cost += 0.5 * term.chi2;
    }
    return cost;
  };

  MotionOnlyBAReport report;
  // Initial state: unprojectable terms cannot be linearized and start as outliers.
  for (MotionOnlyPointTerm& term : *points) {
    term.chi2 = point_chi2(term);
    if (!std::isfinite(term.chi2)) term.inlier = false;
  }
  for (size_t i = 0; i < num_lines; ++i) {
    MotionOnlyLineTerm& term = (*lines)[i];
    term.chi2 = line_chi2(i, false);
    if (!std::isfinite(term.chi2)) term.inlier = false;
  }
  report.initial_cost = total_cost();

  bool solved_last_round = false;
  for (int round = 0; round < options_.num_rounds; ++round) {
    const bool robust = round < options_.robust_rounds;
    solved_last_round = RunLevenbergMarquardt(camera, robust, cam_from_world, *points, lines,
                                              &report.num_iterations);
    int num_inliers = 0;
    for (MotionOnlyPointTerm& term : *points) {
      term.chi2 = point_chi2(term);
      term.inlier = term.chi2 <= options_.point_chi2_threshold;
      num_inliers += term.inlier;
    }
    for (size_t i = 0; i < num_lines; ++i) {
      MotionOnlyLineTerm& term = (*lines)[i];
      term.chi2 = line_chi2(i, !term.inlier);
      term.inlier = term.chi2 <= options_.line_chi2_threshold;
      num_inliers += term.inlier;
    }
    if (num_inliers == 0) {
      solved_last_round = false;
      break;
    }
  }
  for (const MotionOnlyPointTerm& term : *points) report.num_point_inliers += term.inlier;
  for (const MotionOnlyLineTerm& term : *lines) report.num_line_inliers += term.inlier;
  report.final_cost = total_cost();
  report.success = solved_last_round;
  return report;
}

}  // namespace lcv::slam
