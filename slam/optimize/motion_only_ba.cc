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

// ReprojectionResidual with the pose's rotation matrix computed once per pass over the terms
// (the same arithmetic, so the same bits).
inline bool Reproject(const Camera& camera, const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                      const Eigen::Vector3d& p_in_world, const Eigen::Vector2d& observed_px,
                      Eigen::Vector2d* residual_px, Matrix26d* J_r_pose,
                      Matrix23d* J_r_point) {
  const Eigen::Vector3d p_in_cam = R * p_in_world + t;
  Matrix23d J_px_p;
  const std::optional<Eigen::Vector2d> px = camera.Project(p_in_cam, &J_px_p);
  if (!px) return false;
  *residual_px = *px - observed_px;
  J_r_pose->leftCols<3>() = J_px_p;
  J_r_pose->rightCols<3>() = -J_px_p * SkewSymmetric(p_in_cam);
  if (J_r_point) *J_r_point = J_px_p * R;
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

bool MotionOnlyBA::Evaluate(const Camera& camera, const Rigid3d& cam_from_world,
                            const std::vector<MotionOnlyPointTerm>& points,
                            const std::vector<MotionOnlyLineTerm>& lines,
                            const std::vector<Eigen::Vector3d>& restored_points,
                            Linearization* out) const {
  const Eigen::Matrix3d R = cam_from_world.RotationMatrix();
  const Eigen::Vector3d& t = cam_from_world.translation;
  for (size_t i = 0; i < points.size(); ++i) {
    const MotionOnlyPointTerm& term = points[i];
    if (!term.inlier) continue;
    PointTermEvaluation& e = out->point_terms[i];
    if (!Reproject(camera, R, t, term.p_in_world, term.observed_px, &e.r, &e.J_pose, nullptr)) {
      return false;
    }
  }
  for (size_t i = 0; i < lines.size(); ++i) {
    const MotionOnlyLineTerm& term = lines[i];
    if (!term.inlier) continue;
    LineTermEvaluation& e = out->line_terms[i];
    if (!Reproject(camera, R, t, restored_points[i], term.observed_px, &e.r, &e.J_pose,
                   &e.J_point)) {
      return false;
    }
  }
  return true;
}

void MotionOnlyBA::Accumulate(const std::vector<MotionOnlyPointTerm>& points,
                              const std::vector<MotionOnlyLineTerm>& lines,
                              const std::vector<Eigen::Vector3d>& restored_points, bool robust,
                              Linearization* out) const {
  out->H_pose_pose.setZero();
  out->g_pose.setZero();
  out->cost = 0.0;
  for (size_t i = 0; i < points.size(); ++i) {
    const MotionOnlyPointTerm& term = points[i];
    if (!term.inlier) continue;
    const PointTermEvaluation& e = out->point_terms[i];
    const Robust k = Huber(term.information * e.r.squaredNorm(), options_.point_chi2_threshold,
                           robust);
    const double w = k.weight * term.information;
    out->H_pose_pose.noalias() += w * e.J_pose.transpose() * e.J_pose;
    out->g_pose.noalias() += w * e.J_pose.transpose() * e.r;
    out->cost += 0.5 * k.rho;
  }
  const double line_weight = options_.line_weight;
  for (size_t i = 0; i < lines.size(); ++i) {
    const MotionOnlyLineTerm& term = lines[i];
    if (!term.inlier) continue;
    const LineTermEvaluation& e = out->line_terms[i];
    const Eigen::Vector3d& x = restored_points[i];
    const Eigen::Matrix3d& A = line_jacobians_[i];
    const Eigen::Vector3d r_line = A * (x - term.line.anchor);
    const double chi2 = term.information * e.r.squaredNorm() + line_weight * r_line.squaredNorm();
    const Robust k = Huber(chi2, options_.line_chi2_threshold, robust);
    const double w = k.weight * term.information;
    const double w_line = k.weight * line_weight;
    LineBlock& block = out->lines[i];
    out->H_pose_pose.noalias() += w * e.J_pose.transpose() * e.J_pose;
    out->g_pose.noalias() += w * e.J_pose.transpose() * e.r;
    block.H_pose_point.noalias() = w * e.J_pose.transpose() * e.J_point;
    block.H_point_point.noalias() = w * e.J_point.transpose() * e.J_point;
    block.H_point_point.noalias() += w_line * A.transpose() * A;
    block.g_point.noalias() = w * e.J_point.transpose() * e.r;
    block.g_point.noalias() += w_line * A.transpose() * r_line;
    out->cost += 0.5 * k.rho;
  }
}

bool MotionOnlyBA::RunLevenbergMarquardt(const Camera& camera, bool robust,
                                         Rigid3d* cam_from_world,
                                         const std::vector<MotionOnlyPointTerm>& points,
                                         std::vector<MotionOnlyLineTerm>* lines,
                                         int* num_iterations) {
  const size_t num_lines = lines->size();
  for (size_t i = 0; i < num_lines; ++i) current_points_[i] = (*lines)[i].restored_point;
  Accumulate(points, *lines, current_points_, robust, &current_);
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
    if (!reduce(lambda)) break;
    const Eigen::LDLT<Matrix6d> ldlt(S);
    if (!full_rank(ldlt)) break;
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
    const bool valid =
        Evaluate(camera, candidate_pose, points, *lines, candidate_points_, &candidate_);
    if (valid) Accumulate(points, *lines, candidate_points_, robust, &candidate_);
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
  // Every exit writes the X' of the accepted steps back: current_ was evaluated at them, and the
  // reclassification reads both.
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
  for (Linearization* l : {&current_, &candidate_}) {
    l->lines.resize(num_lines);
    l->point_terms.resize(points->size());
    l->line_terms.resize(num_lines);
  }
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
  // A term's chi^2 at *cam_from_world (PointTermChi2 / LineTermChi2), from its evaluation in
  // current_ when the last LM step evaluated it there (evaluated = it was active), else
  // evaluated now and stored in current_ for the next round; infinity when not projectable.
  auto point_chi2 = [&](size_t i, bool evaluated, const Eigen::Matrix3d& R) {
    const MotionOnlyPointTerm& term = (*points)[i];
    PointTermEvaluation& e = current_.point_terms[i];
    if (!evaluated && !Reproject(camera, R, cam_from_world->translation, term.p_in_world,
                                 term.observed_px, &e.r, &e.J_pose, nullptr)) {
      return std::numeric_limits<double>::infinity();
    }
    return term.information * e.r.squaredNorm();
  };
  auto line_chi2 = [&](size_t i, bool evaluated, bool refit, const Eigen::Matrix3d& R) {
    MotionOnlyLineTerm& term = (*lines)[i];
    if (refit) {
      internal::RefitRestoredPoint(camera, *cam_from_world, line_jacobians_[i], line_weight,
                                   &term);
    }
    LineTermEvaluation& e = current_.line_terms[i];
    if (!evaluated && !Reproject(camera, R, cam_from_world->translation, term.restored_point,
                                 term.observed_px, &e.r, &e.J_pose, &e.J_point)) {
      return std::numeric_limits<double>::infinity();
    }
    const Eigen::Vector3d r_line = line_jacobians_[i] * (term.restored_point - term.line.anchor);
    return term.information * e.r.squaredNorm() + line_weight * r_line.squaredNorm();
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
  {
    const Eigen::Matrix3d R = cam_from_world->RotationMatrix();
    for (size_t i = 0; i < points->size(); ++i) {
      MotionOnlyPointTerm& term = (*points)[i];
      term.chi2 = point_chi2(i, false, R);
      if (!std::isfinite(term.chi2)) term.inlier = false;
    }
    for (size_t i = 0; i < num_lines; ++i) {
      MotionOnlyLineTerm& term = (*lines)[i];
      term.chi2 = line_chi2(i, false, false, R);
      if (!std::isfinite(term.chi2)) term.inlier = false;
    }
  }
  report.initial_cost = total_cost();

  bool solved_last_round = false;
  for (int round = 0; round < options_.num_rounds; ++round) {
    const bool robust = round < options_.robust_rounds;
    solved_last_round = RunLevenbergMarquardt(camera, robust, cam_from_world, *points, lines,
                                              &report.num_iterations);
    // current_ holds the active terms' evaluations at the round's final pose.
    const Eigen::Matrix3d R = cam_from_world->RotationMatrix();
    int num_inliers = 0;
    for (size_t i = 0; i < points->size(); ++i) {
      MotionOnlyPointTerm& term = (*points)[i];
      term.chi2 = point_chi2(i, term.inlier, R);
      term.inlier = term.chi2 <= options_.point_chi2_threshold;
      num_inliers += term.inlier;
    }
    for (size_t i = 0; i < num_lines; ++i) {
      MotionOnlyLineTerm& term = (*lines)[i];
      const bool was_inlier = term.inlier;
      term.chi2 = line_chi2(i, was_inlier, !was_inlier, R);
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
