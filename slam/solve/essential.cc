#include "slam/solve/essential.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/SVD>

#include "slam/solve/triangulation.h"

namespace lcv::slam {
namespace {

// Least-squares E from the pairs listed in `indices` (all when null): the eigenvector of A^T A
// with the smallest eigenvalue, A's rows being kron(x2, x1) for x2^T E x1 = 0. Accumulating the
// 9x9 A^T A keeps the minimal and the all-inliers solves allocation-free.
int EightPoint(const Eigen::Vector3d* bearings1, const Eigen::Vector3d* bearings2, int count,
               const std::vector<int>* indices, Eigen::Matrix3d* E) {
  const int n = indices ? static_cast<int>(indices->size()) : count;
  if (n < 8) return 0;
  Eigen::Matrix<double, 9, 9> AtA = Eigen::Matrix<double, 9, 9>::Zero();
  for (int k = 0; k < n; ++k) {
    const int i = indices ? (*indices)[k] : k;
    const Eigen::Vector3d x1 = bearings1[i].normalized();
    const Eigen::Vector3d x2 = bearings2[i].normalized();
    Eigen::Matrix<double, 9, 1> row;
    for (int r = 0; r < 3; ++r) row.segment<3>(3 * r) = x2(r) * x1;
    AtA.selfadjointView<Eigen::Lower>().rankUpdate(row);
  }
  AtA = AtA.selfadjointView<Eigen::Lower>();
  if (!AtA.allFinite()) return 0;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eigen(AtA);
  if (eigen.info() != Eigen::Success) return 0;
  const auto& values = eigen.eigenvalues();  // ascending
  // Rank of A below 8: the null space is more than one-dimensional, E is not determined.
  if (!(values(1) > 1e-12 * values(8))) return 0;
  const Eigen::Matrix<double, 9, 1> e = eigen.eigenvectors().col(0);
  Eigen::Matrix3d E_raw;
  E_raw << e(0), e(1), e(2), e(3), e(4), e(5), e(6), e(7), e(8);
  // Project onto the essential manifold: singular values (1, 1, 0).
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(E_raw, Eigen::ComputeFullU | Eigen::ComputeFullV);
  *E = svd.matrixU() * Eigen::Vector3d(1.0, 1.0, 0.0).asDiagonal() * svd.matrixV().transpose();
  return E->allFinite() ? 1 : 0;
}

// Nearest essential matrix: singular values (1, 1, 0).
Eigen::Matrix3d ProjectToEssential(const Eigen::Matrix3d& M) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  return svd.matrixU() * Eigen::Vector3d(1.0, 1.0, 0.0).asDiagonal() * svd.matrixV().transpose();
}

}  // namespace

int EssentialMatrixSevenPoint(const Eigen::Vector3d* bearings1, const Eigen::Vector3d* bearings2,
                              std::vector<Eigen::Matrix3d>* E) {
  E->clear();
  Eigen::Matrix<double, 9, 9> AtA = Eigen::Matrix<double, 9, 9>::Zero();
  for (int i = 0; i < 7; ++i) {
    const Eigen::Vector3d x1 = bearings1[i].normalized();
    const Eigen::Vector3d x2 = bearings2[i].normalized();
    Eigen::Matrix<double, 9, 1> row;
    for (int r = 0; r < 3; ++r) row.segment<3>(3 * r) = x2(r) * x1;
    AtA.selfadjointView<Eigen::Lower>().rankUpdate(row);
  }
  AtA = AtA.selfadjointView<Eigen::Lower>();
  if (!AtA.allFinite()) return 0;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eigen(AtA);
  if (eigen.info() != Eigen::Success) return 0;
  // Rank 7 expected: a larger null space leaves E undetermined.
  if (!(eigen.eigenvalues()(2) > 1e-12 * eigen.eigenvalues()(8))) return 0;
  auto to_matrix = [](const Eigen::Matrix<double, 9, 1>& e) {
    Eigen::Matrix3d m;
    m << e(0), e(1), e(2), e(3), e(4), e(5), e(6), e(7), e(8);
    return m;
  };
  const Eigen::Matrix3d F1 = to_matrix(eigen.eigenvectors().col(0));
  const Eigen::Matrix3d F2 = to_matrix(eigen.eigenvectors().col(1));
  // det(F2 + a F1) = c3 a^3 + c2 a^2 + c1 a + c0 from four evaluations; the root a = infinity
  // (F1 itself singular) shows as c3 = 0.
  const double p0 = F2.determinant();
  const double p1 = (F2 + F1).determinant();
  const double pm1 = (F2 - F1).determinant();
  const double p2 = (F2 + 2.0 * F1).determinant();
  const double c0 = p0;
  const double c2 = 0.5 * (p1 + pm1) - c0;
  const double odd = 0.5 * (p1 - pm1);
  const double c3 = ((p2 - c0 - 4.0 * c2) / 2.0 - odd) / 3.0;
  const double c1 = odd - c3;
  const double scale = std::abs(c0) + std::abs(c1) + std::abs(c2) + std::abs(c3);
  if (!(scale > 0.0)) return 0;
  std::vector<double> roots;
  if (std::abs(c3) > 1e-12 * scale) {
    // Real roots of the monic cubic (trigonometric / Cardano), polished by Newton.
    const double a = c2 / c3, b = c1 / c3, c = c0 / c3;
    const double Q = (a * a - 3.0 * b) / 9.0;
    const double R = (2.0 * a * a * a - 9.0 * a * b + 27.0 * c) / 54.0;
    if (R * R < Q * Q * Q) {
      const double theta = std::acos(std::clamp(R / std::sqrt(Q * Q * Q), -1.0, 1.0));
      const double sq = -2.0 * std::sqrt(Q);
      for (int k = 0; k < 3; ++k) {
        roots.push_back(sq * std::cos((theta + 2.0 * M_PI * k) / 3.0) - a / 3.0);
      }
    } else {
      const double A = -std::copysign(std::cbrt(std::abs(R) + std::sqrt(R * R - Q * Q * Q)), R);
      roots.push_back(A + (A != 0.0 ? Q / A : 0.0) - a / 3.0);
    }
    for (double& root : roots) {
      for (int it = 0; it < 2; ++it) {
        const double f = ((root + a) * root + b) * root + c;
        const double df = (3.0 * root + 2.0 * a) * root + b;
        if (std::abs(df) > 1e-300) root -= f / df;
      }
    }
  } else {
    E->push_back(ProjectToEssential(F1));  // the root at infinity
    if (std::abs(c2) > 1e-12 * scale) {
      const double disc = c1 * c1 - 4.0 * c2 * c0;
      if (disc >= 0.0) {
        roots.push_back((-c1 + std::sqrt(disc)) / (2.0 * c2));
        roots.push_back((-c1 - std::sqrt(disc)) / (2.0 * c2));
      }
    }
  }
  for (const double root : roots) {
    if (!std::isfinite(root)) continue;
    const Eigen::Matrix3d candidate = ProjectToEssential(F2 + root * F1);
    if (candidate.allFinite()) E->push_back(candidate);
  }
  return static_cast<int>(E->size());
}

int EssentialMatrixEightPoint(const Eigen::Vector3d* bearings1, const Eigen::Vector3d* bearings2,
                              int count, Eigen::Matrix3d* E) {
  return EightPoint(bearings1, bearings2, count, nullptr, E);
}

void DecomposeEssentialMatrix(const Eigen::Matrix3d& E, Eigen::Matrix3d* R1, Eigen::Matrix3d* R2,
                              Eigen::Vector3d* t) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(E, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU();
  Eigen::Matrix3d V = svd.matrixV();
  // E is defined up to sign, so flipping a column of U or V keeps a valid decomposition while
  // making both proper rotations.
  if (U.determinant() < 0) U.col(2) *= -1.0;
  if (V.determinant() < 0) V.col(2) *= -1.0;
  Eigen::Matrix3d W;
  W << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  *R1 = U * W * V.transpose();
  *R2 = U * W.transpose() * V.transpose();
  *t = U.col(2).normalized();
}

double SquaredEpipolarAngleError(const Eigen::Matrix3d& E, const Eigen::Vector3d& x1,
                                 const Eigen::Vector3d& x2) {
  const Eigen::Vector3d u1 = x1.normalized();
  const Eigen::Vector3d u2 = x2.normalized();
  const Eigen::Vector3d normal2 = E * u1;               // epipolar plane normal in camera 2
  const Eigen::Vector3d normal1 = E.transpose() * u2;   // and in camera 1
  const double n2 = normal2.squaredNorm();
  const double n1 = normal1.squaredNorm();
  if (!(n1 > 1e-300) || !(n2 > 1e-300)) return 1.0;
  const double algebraic = u2.dot(normal2);
  const double algebraic_sq = algebraic * algebraic;
  return 0.5 * (algebraic_sq / n2 + algebraic_sq / n1);
}

int PoseFromEssentialMatrix(const Eigen::Matrix3d& E, const Eigen::Vector3d* bearings1,
                            const Eigen::Vector3d* bearings2, int count, const char* mask,
                            Rigid3d* cam2_from_cam1) {
  if (!E.allFinite() || E.norm() < 1e-12) return 0;
  Eigen::Matrix3d R1, R2;
  Eigen::Vector3d t;
  DecomposeEssentialMatrix(E, &R1, &R2, &t);
  const Eigen::Matrix3d rotations[4] = {R1, R1, R2, R2};
  const Eigen::Vector3d translations[4] = {t, -t, t, -t};
  const Rigid3d identity;
  int best_count = 0;
  for (int c = 0; c < 4; ++c) {
    Eigen::Quaterniond q(rotations[c]);
    q.normalize();
    const Rigid3d candidate(q, translations[c]);
    int in_front = 0;
    for (int i = 0; i < count; ++i) {
      if (mask && !mask[i]) continue;
      if (TriangulateBearings(identity, candidate, bearings1[i], bearings2[i])) ++in_front;
    }
    if (in_front > best_count) {
      best_count = in_front;
      *cam2_from_cam1 = candidate;
    }
  }
  return best_count;
}

double EpipolarSine(const Rigid3d& cam2_from_cam1, const Eigen::Vector3d& x1,
                    const Eigen::Vector3d& x2) {
  const Eigen::Vector3d n = cam2_from_cam1.translation.cross(cam2_from_cam1.rotation * x1);
  const double norm = n.norm();
  if (!(norm > 1e-300)) return 0.0;
  return x2.dot(n) / norm;
}

int RefineRelativePose(const Eigen::Vector3d* bearings1, const Eigen::Vector3d* bearings2,
                       int count_all, const std::vector<int>* indices, int max_iterations,
                       Rigid3d* cam2_from_cam1) {
  const int count = indices ? static_cast<int>(indices->size()) : count_all;
  if (count < 5 || !(cam2_from_cam1->translation.norm() > 0.0)) return -1;
  Rigid3d pose(cam2_from_cam1->rotation, cam2_from_cam1->translation.normalized());
  auto cost_of = [&](const Rigid3d& candidate) {
    double cost = 0.0;
    for (int k = 0; k < count; ++k) {
      const int i = indices ? (*indices)[k] : k;
      const double r = EpipolarSine(candidate, bearings1[i], bearings2[i]);
      cost += r * r;
    }
    return cost;
  };
  double cost = cost_of(pose);
  int iteration = 0;
  for (; iteration < max_iterations; ++iteration) {
    // Tangent basis of the translation direction.
    const Eigen::Vector3d& t = pose.translation;
    const Eigen::Vector3d helper =
        std::abs(t.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    Eigen::Matrix<double, 3, 2> B;
    B.col(0) = (helper - t.dot(helper) * t).normalized();
    B.col(1) = t.cross(B.col(0));
    Eigen::Matrix<double, 5, 5> H = Eigen::Matrix<double, 5, 5>::Zero();
    Eigen::Matrix<double, 5, 1> g = Eigen::Matrix<double, 5, 1>::Zero();
    for (int k = 0; k < count; ++k) {
      const int i = indices ? (*indices)[k] : k;
      const Eigen::Vector3d a = pose.rotation * bearings1[i];
      const Eigen::Vector3d n = t.cross(a);
      const double norm = n.norm();
      if (!(norm > 1e-12)) continue;
      const Eigen::Vector3d& x2 = bearings2[i];
      const double r = x2.dot(n) / norm;
      // dr/dn = (x2 - r n/|n|)^T / |n|; dn/domega = -[t]x [a]x; dn/ddelta = -[a]x B.
      const Eigen::RowVector3d J_r_n = (x2 - r * n / norm).transpose() / norm;
      Eigen::Matrix<double, 1, 5> J;
      J.leftCols<3>() = -J_r_n * SkewSymmetric(t) * SkewSymmetric(a);
      J.rightCols<2>() = -J_r_n * SkewSymmetric(a) * B;
      H.noalias() += J.transpose() * J;
      g.noalias() += J.transpose() * r;
    }
    const Eigen::LDLT<Eigen::Matrix<double, 5, 5>> ldlt(H);
    if (ldlt.info() != Eigen::Success) break;
    Eigen::Matrix<double, 5, 1> step = -ldlt.solve(g);
    if (!step.allFinite()) break;
    bool accepted = false;
    for (int halving = 0; halving < 8 && !accepted; ++halving, step *= 0.5) {
      const Rigid3d candidate(ExpSO3(step.head<3>()) * pose.rotation,
                              (t + B * step.tail<2>()).normalized());
      const double candidate_cost = cost_of(candidate);
      if (candidate_cost <= cost) {
        pose = candidate;
        cost = candidate_cost;
        accepted = true;
      }
    }
    if (!accepted || step.norm() < 1e-12) {
      ++iteration;
      break;
    }
  }
  *cam2_from_cam1 = pose;
  return iteration;
}

void EssentialMatrixEstimator::Estimate(const std::vector<int>& sample,
                                        std::vector<Model>* models) const {
  Eigen::Vector3d x1[kMinNumSamples], x2[kMinNumSamples];
  for (int k = 0; k < kMinNumSamples; ++k) {
    x1[k] = bearings1_[sample[k]];
    x2[k] = bearings2_[sample[k]];
  }
  EssentialMatrixSevenPoint(x1, x2, models);
}

void EssentialMatrixEstimator::Residuals(const Model& E,
                                         std::vector<double>* squared_residuals) const {
  // SquaredEpipolarAngleError without re-normalizing the (unit) bearings: this loop is most of
  // the cost of RANSAC.
  squared_residuals->resize(count_);
  const Eigen::Matrix3d Et = E.transpose();
  for (int i = 0; i < count_; ++i) {
    const Eigen::Vector3d normal2 = E * bearings1_[i];
    const Eigen::Vector3d normal1 = Et * bearings2_[i];
    const double n2 = normal2.squaredNorm(), n1 = normal1.squaredNorm();
    if (!(n1 > 1e-300) || !(n2 > 1e-300)) {
      (*squared_residuals)[i] = 1.0;
      continue;
    }
    const double algebraic = bearings2_[i].dot(normal2);
    (*squared_residuals)[i] = 0.5 * algebraic * algebraic * (1.0 / n2 + 1.0 / n1);
  }
}

bool EssentialMatrixEstimator::Refine(const std::vector<int>& inliers, Model* E) const {
  Eigen::Matrix3d refined;
  if (!EightPoint(bearings1_, bearings2_, count_, &inliers, &refined)) return false;
  *E = refined;
  return true;
}

}  // namespace lcv::slam
