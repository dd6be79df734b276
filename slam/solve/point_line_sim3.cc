#include "slam/solve/point_line_sim3.h"

#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

namespace lcv::slam {
namespace {

// Orthonormal basis (columns) of the plane orthogonal to the unit direction d.
Eigen::Matrix<double, 3, 2> NormalBasis(const Eigen::Vector3d& d) {
  const Eigen::Vector3d helper =
      std::abs(d.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  Eigen::Matrix<double, 3, 2> basis;
  basis.col(0) = (helper - d.dot(helper) * d).normalized();
  basis.col(1) = d.cross(basis.col(0));
  return basis;
}

double Cost(const Eigen::Vector3d* points, const Line3d* lines, int count,
            const std::vector<int>* indices, const Sim3d& S) {
  double cost = 0.0;
  for (int k = 0; k < count; ++k) {
    const int i = indices ? (*indices)[k] : k;
    cost += SquaredPointLineDistance(S, points[i], lines[i]);
  }
  return cost;
}

}  // namespace

double SquaredPointLineDistance(const Sim3d& server_from_client, const Eigen::Vector3d& point,
                                const Line3d& line) {
  return line.Residual(server_from_client * point).squaredNorm();
}

int SolveSim3PointLineLinear(const Eigen::Vector3d* points, const Line3d* lines, int count_all,
                             const std::vector<int>* indices, Sim3d* server_from_client) {
  const int count = indices ? static_cast<int>(indices->size()) : count_all;
  if (count < 6) return 0;
  // Centre the points for conditioning: X = X_c + mean, t' = t + M mean.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int k = 0; k < count; ++k) mean += points[indices ? (*indices)[k] : k];
  mean /= count;
  double spread = 0.0;
  for (int k = 0; k < count; ++k) spread += (points[indices ? (*indices)[k] : k] - mean).norm();
  spread /= count;
  if (!(spread > 0.0) || !std::isfinite(spread)) return 0;

  // Unknowns z = [vec(M) row-major (9); t' (3)] with M = s R / spread-normalized points.
  Eigen::Matrix<double, 12, 12> AtA = Eigen::Matrix<double, 12, 12>::Zero();
  Eigen::Matrix<double, 12, 1> Atb = Eigen::Matrix<double, 12, 1>::Zero();
  for (int k = 0; k < count; ++k) {
    const int i = indices ? (*indices)[k] : k;
    const Eigen::Vector3d X = (points[i] - mean) / spread;
    const Eigen::Matrix3d P =
        Eigen::Matrix3d::Identity() - lines[i].direction * lines[i].direction.transpose();
    Eigen::Matrix<double, 3, 12> A;
    for (int r = 0; r < 3; ++r) {
      A.block<3, 3>(0, 3 * r) = P.col(r) * X.transpose();  // (P M X): sum_r P(:, r) (M(r, :) X)
    }
    A.rightCols<3>() = P;
    const Eigen::Vector3d b = P * lines[i].anchor;
    AtA.noalias() += A.transpose() * A;
    Atb.noalias() += A.transpose() * b;
  }
  if (!AtA.allFinite() || !Atb.allFinite()) return 0;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 12, 12>> eigen(AtA);
  if (eigen.info() != Eigen::Success) return 0;
  if (!(eigen.eigenvalues()(0) > 1e-10 * eigen.eigenvalues()(11))) return 0;  // rank < 12
  const Eigen::Matrix<double, 12, 1> z = eigen.eigenvectors() *
      (eigen.eigenvalues().cwiseInverse().asDiagonal() * (eigen.eigenvectors().transpose() * Atb));
  Eigen::Matrix3d M;
  M << z(0), z(1), z(2), z(3), z(4), z(5), z(6), z(7), z(8);
  // Nearest scaled rotation (polar decomposition).
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) D(2, 2) = -1.0;
  const Eigen::Matrix3d R = svd.matrixU() * D * svd.matrixV().transpose();
  const double s_normalized = (svd.singularValues().asDiagonal() * D).trace() / 3.0;
  if (!(s_normalized > 0.0)) return 0;
  const double s = s_normalized / spread;
  // t from the lines given s R: (sum P_i) t = sum P_i (p_i - s R X_i).
  Eigen::Matrix3d sum_P = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  for (int k = 0; k < count; ++k) {
    const int i = indices ? (*indices)[k] : k;
    const Eigen::Matrix3d P =
        Eigen::Matrix3d::Identity() - lines[i].direction * lines[i].direction.transpose();
    sum_P += P;
    rhs += P * (lines[i].anchor - s * (R * points[i]));
  }
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(sum_P);
  const Eigen::Vector3d t = ldlt.solve(rhs);
  Eigen::Quaterniond q(R);
  q.normalize();
  if (!t.allFinite() || !q.coeffs().allFinite() || !std::isfinite(s)) return 0;
  *server_from_client = Sim3d(s, q, t);
  return 1;
}

int RefineSim3PointLine(const Eigen::Vector3d* points, const Line3d* lines, int count_all,
                        const std::vector<int>* indices, int max_iterations,
                        Sim3d* server_from_client, double* final_cost) {
  const int count = indices ? static_cast<int>(indices->size()) : count_all;
  if (count < 4) return -1;
  Sim3d S = *server_from_client;
  double cost = Cost(points, lines, count, indices, S);
  int iteration = 0;
  for (; iteration < max_iterations; ++iteration) {
    Eigen::Matrix<double, 7, 7> H = Eigen::Matrix<double, 7, 7>::Zero();
    Vector7d g = Vector7d::Zero();
    for (int k = 0; k < count; ++k) {
      const int i = indices ? (*indices)[k] : k;
      const Eigen::Vector3d y = S * points[i];
      const Eigen::Matrix<double, 3, 2> B = NormalBasis(lines[i].direction);
      const Eigen::Vector2d r = B.transpose() * (y - lines[i].anchor);
      // dy/ddelta = [I, -[y]x, y] for S <- Exp([v; omega; sigma]) S.
      Eigen::Matrix<double, 3, 7> J_y;
      J_y.leftCols<3>().setIdentity();
      J_y.block<3, 3>(0, 3) = -SkewSymmetric(y);
      J_y.col(6) = y;
      const Eigen::Matrix<double, 2, 7> J = B.transpose() * J_y;
      H.noalias() += J.transpose() * J;
      g.noalias() += J.transpose() * r;
    }
    const Eigen::LDLT<Eigen::Matrix<double, 7, 7>> ldlt(H);
    if (ldlt.info() != Eigen::Success) break;
    Vector7d step = -ldlt.solve(g);
    if (!step.allFinite()) break;
    bool accepted = false;
    for (int halving = 0; halving < 8 && !accepted; ++halving) {
      const Sim3d candidate = Sim3d::Exp(step) * S;
      const double candidate_cost = Cost(points, lines, count, indices, candidate);
      if (candidate_cost <= cost) {
        S = candidate;
        cost = candidate_cost;
        accepted = true;
      } else {
        step *= 0.5;
      }
    }
    if (!accepted || step.norm() < 1e-12) {
      ++iteration;
      break;
    }
  }
  *server_from_client = S;
  if (final_cost) *final_cost = cost;
  return iteration;
}

void Sim3PointLineEstimator::Estimate(const std::vector<int>& sample,
                                      std::vector<Model>* models) const {
  models->clear();
  Sim3d S;
  if (SolveSim3PointLineLinear(points_, lines_, count_, &sample, &S)) models->push_back(S);
}

void Sim3PointLineEstimator::Residuals(const Model& S,
                                       std::vector<double>* squared_residuals) const {
  squared_residuals->resize(count_);
  for (int i = 0; i < count_; ++i) {
    (*squared_residuals)[i] = SquaredPointLineDistance(S, points_[i], lines_[i]);
  }
}

bool Sim3PointLineEstimator::Refine(const std::vector<int>& inliers, Model* S) const {
  Sim3d refined = *S;
  if (RefineSim3PointLine(points_, lines_, count_, &inliers, 5, &refined) < 0) return false;
  *S = refined;
  return true;
}

}  // namespace lcv::slam
