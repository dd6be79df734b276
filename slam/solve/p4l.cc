#include "slam/solve/p4l.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "slam/solve/point_line_sim3.h"

namespace lcv::slam {
namespace {

using Matrix9d = Eigen::Matrix<double, 9, 9>;
using Vector9d = Eigen::Matrix<double, 9, 1>;
using Matrix4x9d = Eigen::Matrix<double, 4, 9>;

Vector9d VecRowMajor(const Eigen::Matrix3d& R) {
  Vector9d r;
  r << R(0, 0), R(0, 1), R(0, 2), R(1, 0), R(1, 1), R(1, 2), R(2, 0), R(2, 1), R(2, 2);
  return r;
}

// The 24 proper rotations mapping the coordinate axes onto signed axes (the cube group).
std::vector<Eigen::Matrix3d> CubeRotations() {
  std::vector<Eigen::Matrix3d> out;
  const int permutations[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (const auto& p : permutations) {
    for (int signs = 0; signs < 8; ++signs) {
      Eigen::Matrix3d R = Eigen::Matrix3d::Zero();
      for (int row = 0; row < 3; ++row) R(row, p[row]) = (signs >> row) & 1 ? -1.0 : 1.0;
      if (R.determinant() > 0) out.push_back(R);
    }
  }
  return out;
}

// The elimination of (t, s) given vec(R) = r, after a_i (projection orthogonal to d_i):
// residual_i = P_i K_i r + G_i w, w = [t; s], G_i = [P_i, -P_i p_i], K_i r = R X_i.
struct Elimination {
  Matrix9d M;              // J(R) = r^T M r
  Matrix4x9d w_from_r;     // w* = w_from_r * r
};

bool Eliminate(const Eigen::Vector3d* points, const Line3d* lines, int count,
               const std::vector<int>* indices, Elimination* out) {
  Matrix9d HtH = Matrix9d::Zero();
  Matrix4x9d GtH = Matrix4x9d::Zero();
  Eigen::Matrix4d GtG = Eigen::Matrix4d::Zero();
  for (int k = 0; k < count; ++k) {
    const int i = indices ? (*indices)[k] : k;
    const Eigen::Vector3d& d = lines[i].direction;
    const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - d * d.transpose();
    Eigen::Matrix<double, 3, 9> K = Eigen::Matrix<double, 3, 9>::Zero();
    for (int row = 0; row < 3; ++row) K.block<1, 3>(row, 3 * row) = points[i].transpose();
    const Eigen::Matrix<double, 3, 9> PK = P * K;
    Eigen::Matrix<double, 3, 4> G;
    G.leftCols<3>() = P;
    G.col(3) = -(P * lines[i].anchor);
    HtH.noalias() += K.transpose() * PK;  // P symmetric idempotent: (PK)^T PK = K^T P K
    GtH.noalias() += G.transpose() * PK;
    GtG.noalias() += G.transpose() * G;
  }
  if (!GtG.allFinite() || !HtH.allFinite()) return false;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eigen(GtG);
  if (eigen.info() != Eigen::Success) return false;
  if (!(eigen.eigenvalues()(0) > 1e-10 * eigen.eigenvalues()(3))) return false;
  const Eigen::Matrix4d GtG_inverse = eigen.eigenvectors() *
                                      eigen.eigenvalues().cwiseInverse().asDiagonal() *
                                      eigen.eigenvectors().transpose();
  out->w_from_r = -GtG_inverse * GtH;
  out->M = HtH - GtH.transpose() * GtG_inverse * GtH;
  out->M = 0.5 * (out->M + out->M.transpose());
  return out->M.allFinite();
}

// Gauss-Newton with Levenberg damping on J(R) = |L vec(R)|^2, R <- Exp(omega) R.
Eigen::Matrix3d MinimizeOnSO3(const Matrix9d& L, Eigen::Matrix3d R, double* cost) {
  double lambda = 1e-6;
  Vector9d e = L * VecRowMajor(R);
  double current = e.squaredNorm();
  for (int iteration = 0; iteration < 30; ++iteration) {
    // d vec(R) / d omega_k = vec([e_k]x R).
    Eigen::Matrix<double, 9, 3> J;
    for (int k = 0; k < 3; ++k) {
      J.col(k) = L * VecRowMajor(SkewSymmetric(Eigen::Vector3d::Unit(k)) * R);
    }
    const Eigen::Matrix3d H = J.transpose() * J;
    const Eigen::Vector3d g = J.transpose() * e;
    bool improved = false;
    for (int attempt = 0; attempt < 6 && !improved; ++attempt) {
      Eigen::Matrix3d damped = H;
      damped.diagonal() *= 1.0 + lambda;
      const Eigen::Vector3d omega = -damped.ldlt().solve(g);
      if (!omega.allFinite()) break;
      const Eigen::Matrix3d candidate = ExpSO3(omega).toRotationMatrix() * R;
      const Vector9d candidate_e = L * VecRowMajor(candidate);
      const double candidate_cost = candidate_e.squaredNorm();
      if (candidate_cost < current) {
        R = candidate;
        e = candidate_e;
        const double decrease = current - candidate_cost;
        current = candidate_cost;
        lambda = std::max(1e-9, lambda * 0.1);
        improved = true;
        if (omega.norm() < 1e-13 || decrease < 1e-30) iteration = 1000;
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved) break;
  }
  *cost = current;
  return R;
}

}  // namespace

namespace {

// SolveP4L on coordinates of comparable size (see SolveP4L).
int SolveP4LNormalized(const Eigen::Vector3d* points_in_client, const Line3d* server_lines,
                       int count, std::vector<Sim3d>* server_from_client) {
  server_from_client->clear();
  if (count < 4) return 0;
  for (int i = 0; i < count; ++i) {
    if (!points_in_client[i].allFinite() || !server_lines[i].anchor.allFinite() ||
        !server_lines[i].direction.allFinite()) {
      return 0;
    }
  }
  // Collinear (or coincident) points leave the rotation about their line free.
  const Eigen::Vector3d& X0 = points_in_client[0];
  double extent = 0.0, area = 0.0;
  for (int i = 1; i < count; ++i) {
    extent = std::max(extent, (points_in_client[i] - X0).squaredNorm());
    for (int j = i + 1; j < count; ++j) {
      area = std::max(area, (points_in_client[i] - X0).cross(points_in_client[j] - X0).norm());
    }
  }
  if (!(area > 1e-9 * extent) || !(extent > 0.0)) return 0;

  Elimination elimination;
  if (!Eliminate(points_in_client, server_lines, count, nullptr, &elimination)) return 0;
  // M = L^T L with L = sqrt(Lambda) V^T (M is PSD up to rounding).
  const Eigen::SelfAdjointEigenSolver<Matrix9d> eigen(elimination.M);
  if (eigen.info() != Eigen::Success) return 0;
  const Vector9d sqrt_values = eigen.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  const Matrix9d L = sqrt_values.asDiagonal() * eigen.eigenvectors().transpose();
  const double scale = std::max(eigen.eigenvalues()(8), 1e-300);

  struct Candidate {
    Eigen::Matrix3d R;
    double cost;
  };
  std::vector<Candidate> minima;
  static const std::vector<Eigen::Matrix3d> starts = CubeRotations();
  for (const Eigen::Matrix3d& start : starts) {
    double cost = 0.0;
    const Eigen::Matrix3d R = MinimizeOnSO3(L, start, &cost);
    bool duplicate = false;
    for (Candidate& m : minima) {
      if ((m.R - R).norm() < 1e-6) {
        duplicate = true;
        if (cost < m.cost) m = {R, cost};
        break;
      }
    }
    if (!duplicate) minima.push_back({R, cost});
  }
  std::sort(minima.begin(), minima.end(),
            [](const Candidate& a, const Candidate& b) { return a.cost < b.cost; });

  for (const Candidate& m : minima) {
    // Minima far above the best are not solutions (J is 0 at exact ones; with noise the best
    // is small): keep those within a factor of the best plus a floor relative to M's scale.
    if (m.cost > 100.0 * minima.front().cost + 1e-12 * scale) break;
    const Eigen::Vector4d w = elimination.w_from_r * VecRowMajor(m.R);
    const double s = w(3);
    if (!(s > 0.0) || !std::isfinite(s)) continue;
    Eigen::Quaterniond q(m.R);
    q.normalize();
    const Sim3d candidate(1.0 / s, q, w.head<3>() / s);
    if (!candidate.translation.allFinite()) continue;
    server_from_client->push_back(candidate);
    if (server_from_client->size() == 4) break;
  }
  return static_cast<int>(server_from_client->size());
}

}  // namespace

int SolveP4L(const Eigen::Vector3d* points_in_client, const Line3d* server_lines, int count,
             std::vector<Sim3d>* server_from_client) {
  server_from_client->clear();
  if (count < 4) return 0;
  // Normalization (Hartley's, for the same reason): the elimination mixes client coordinates,
  // server coordinates and the scale in one linear system, so a client in units of its scene
  // depth against a server in millimetres (values ~1e4) left it too ill-conditioned to give any
  // model. Both sides are centred and scaled to unit RMS distance, the problem is solved there
  // and the result mapped back; exact, as the equation is Sim(3)-covariant on either side.
  Eigen::Vector3d client_centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d server_centre = Eigen::Vector3d::Zero();
  for (int i = 0; i < count; ++i) {
    client_centre += points_in_client[i];
    server_centre += server_lines[i].anchor;
  }
  client_centre /= count;
  server_centre /= count;
  // Anchors moved to the feet of the server centre: a published anchor can be anywhere on its
  // line (the point closest to the map origin), far from the hidden point.
  std::vector<Line3d> lines(server_lines, server_lines + count);
  for (Line3d& line : lines) line.anchor = line.Project(server_centre);
  double client_spread = 0.0, server_spread = 0.0;
  for (int i = 0; i < count; ++i) {
    client_spread += (points_in_client[i] - client_centre).squaredNorm();
    server_spread += (lines[i].anchor - server_centre).squaredNorm();
  }
  client_spread = std::sqrt(client_spread / count);
  server_spread = std::sqrt(server_spread / count);
  // All points coincident, or all lines through one point: degenerate (see p4l.h).
  if (!(client_spread > 0.0) || !(server_spread > 0.0) || !std::isfinite(client_spread) ||
      !std::isfinite(server_spread)) {
    return 0;
  }
  std::vector<Eigen::Vector3d> points(count);
  for (int i = 0; i < count; ++i) {
    points[i] = (points_in_client[i] - client_centre) / client_spread;
    lines[i].anchor = (lines[i].anchor - server_centre) / server_spread;
  }
  std::vector<Sim3d> normalized;
  SolveP4LNormalized(points.data(), lines.data(), count, &normalized);
  const Sim3d client_normalization(1.0 / client_spread, Eigen::Quaterniond::Identity(),
                                   -client_centre / client_spread);
  const Sim3d server_denormalization(server_spread, Eigen::Quaterniond::Identity(),
                                     server_centre);
  for (const Sim3d& model : normalized) {
    server_from_client->push_back(server_denormalization * model * client_normalization);
  }
  return static_cast<int>(server_from_client->size());
}

void P4LEstimator::Estimate(const std::vector<int>& sample, std::vector<Model>* models) const {
  Eigen::Vector3d points[kMinNumSamples];
  Line3d lines[kMinNumSamples];
  for (int k = 0; k < kMinNumSamples; ++k) {
    points[k] = points_[sample[k]];
    lines[k] = lines_[sample[k]];
  }
  SolveP4L(points, lines, kMinNumSamples, models);
}

void P4LEstimator::Residuals(const Model& S, std::vector<double>* squared_residuals) const {
  squared_residuals->resize(count_);
  for (int i = 0; i < count_; ++i) {
    (*squared_residuals)[i] = SquaredPointLineDistance(S, points_[i], lines_[i]);
  }
}

bool P4LEstimator::Refine(const std::vector<int>& inliers, Model* S) const {
  Sim3d refined = *S;
  if (RefineSim3PointLine(points_, lines_, count_, &inliers, 5, &refined) < 0) return false;
  *S = refined;
  return true;
}

}  // namespace lcv::slam
