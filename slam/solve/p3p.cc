#include "slam/solve/p3p.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/SVD>

namespace lcv::slam {
namespace {

// One real root of c3 g^3 + c2 g^2 + c1 g + c0 (c3 != 0), polished by Newton steps.
double RealCubicRoot(double c3, double c2, double c1, double c0) {
  const double a = c2 / c3, b = c1 / c3, c = c0 / c3;
  const double Q = (a * a - 3.0 * b) / 9.0;
  const double R = (2.0 * a * a * a - 9.0 * a * b + 27.0 * c) / 54.0;
  double root;
  if (R * R < Q * Q * Q) {
    const double theta = std::acos(std::clamp(R / std::sqrt(Q * Q * Q), -1.0, 1.0));
    root = -2.0 * std::sqrt(Q) * std::cos(theta / 3.0) - a / 3.0;
  } else {
    const double A = -std::copysign(std::cbrt(std::abs(R) + std::sqrt(R * R - Q * Q * Q)), R);
    const double B = A != 0.0 ? Q / A : 0.0;
    root = A + B - a / 3.0;
  }
  for (int it = 0; it < 3; ++it) {
    const double f = ((root + a) * root + b) * root + c;
    const double df = (3.0 * root + 2.0 * a) * root + b;
    if (std::abs(df) < 1e-300) break;
    root -= f / df;
  }
  return root;
}

// Residuals f_ij = |l_i x_i - l_j x_j|^2 - a_ij with unit x: l_i^2 + l_j^2 - 2 b_ij l_i l_j - a_ij.
struct DepthConstraints {
  double a01, a02, a12;
  double b01, b02, b12;

  Eigen::Vector3d Residual(const Eigen::Vector3d& l) const {
    return Eigen::Vector3d(l(0) * l(0) + l(1) * l(1) - 2.0 * b01 * l(0) * l(1) - a01,
                           l(0) * l(0) + l(2) * l(2) - 2.0 * b02 * l(0) * l(2) - a02,
                           l(1) * l(1) + l(2) * l(2) - 2.0 * b12 * l(1) * l(2) - a12);
  }
  Eigen::Matrix3d Jacobian(const Eigen::Vector3d& l) const {
    Eigen::Matrix3d J;
    J << 2.0 * (l(0) - b01 * l(1)), 2.0 * (l(1) - b01 * l(0)), 0.0,
        2.0 * (l(0) - b02 * l(2)), 0.0, 2.0 * (l(2) - b02 * l(0)),
        0.0, 2.0 * (l(1) - b12 * l(2)), 2.0 * (l(2) - b12 * l(1));
    return J;
  }
  double A(int i, int j) const {
    if (i > j) std::swap(i, j);
    return i == 0 ? (j == 1 ? a01 : a02) : a12;
  }
  double B(int i, int j) const {
    if (i > j) std::swap(i, j);
    return i == 0 ? (j == 1 ? b01 : b02) : b12;
  }
};

// Quadratic forms M with l^T M l = |l_i x_i - l_j x_j|^2.
Eigen::Matrix3d PairForm(int i, int j, double b) {
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  M(i, i) = 1.0;
  M(j, j) = 1.0;
  M(i, j) = M(j, i) = -b;
  return M;
}

}  // namespace

int SolveP3P(const Eigen::Vector3d* bearings, const Eigen::Vector3d* points_in_world,
             std::vector<Rigid3d>* cam_from_world) {
  cam_from_world->clear();
  const Eigen::Vector3d x[3] = {bearings[0].normalized(), bearings[1].normalized(),
                                bearings[2].normalized()};
  const Eigen::Vector3d* X = points_in_world;
  if (!x[0].allFinite() || !x[1].allFinite() || !x[2].allFinite()) return 0;

  DepthConstraints c;
  c.a01 = (X[0] - X[1]).squaredNorm();
  c.a02 = (X[0] - X[2]).squaredNorm();
  c.a12 = (X[1] - X[2]).squaredNorm();
  c.b01 = x[0].dot(x[1]);
  c.b02 = x[0].dot(x[2]);
  c.b12 = x[1].dot(x[2]);
  const double scale_sq = std::max({c.a01, c.a02, c.a12});
  if (!(scale_sq > 0.0) || !std::isfinite(scale_sq)) return 0;
  // Collinear or coincident world points: the pose is not determined.
  const Eigen::Vector3d X01 = X[0] - X[1], X02 = X[0] - X[2];
  const Eigen::Vector3d X_normal = X01.cross(X02);
  if (X_normal.squaredNorm() < 1e-20 * scale_sq * scale_sq) return 0;
  // Parallel bearings see no triangle.
  for (const double b : {c.b01, c.b02, c.b12}) {
    if (b > 1.0 - 1e-14) return 0;
  }

  // Work in units where the largest distance is 1 (conditioning), rescale at the end.
  const double unit = std::sqrt(scale_sq);
  DepthConstraints cn = c;
  cn.a01 /= scale_sq;
  cn.a02 /= scale_sq;
  cn.a12 /= scale_sq;

  // Homogeneous forms D1 = a12 M01 - a01 M12, D2 = a12 M02 - a02 M12 vanish at the solution;
  // D0 = D1 + g D2 with det(D0) = 0 is a degenerate conic: a pair of planes through the origin.
  const Eigen::Matrix3d M01 = PairForm(0, 1, cn.b01);
  const Eigen::Matrix3d M02 = PairForm(0, 2, cn.b02);
  const Eigen::Matrix3d M12 = PairForm(1, 2, cn.b12);
  const Eigen::Matrix3d D1 = cn.a12 * M01 - cn.a01 * M12;
  const Eigen::Matrix3d D2 = cn.a12 * M02 - cn.a02 * M12;
  // det(D1 + g D2) is a cubic in g; its coefficients from four evaluations.
  const double p0 = D1.determinant();
  const double p1 = (D1 + D2).determinant();
  const double pm1 = (D1 - D2).determinant();
  const double p2 = (D1 + 2.0 * D2).determinant();
  const double c0 = p0;
  const double c2 = 0.5 * (p1 + pm1) - c0;
  const double odd = 0.5 * (p1 - pm1);               // c1 + c3
  const double c3 = ((p2 - c0 - 4.0 * c2) / 2.0 - odd) / 3.0;
  const double c1 = odd - c3;
  Eigen::Matrix3d D0;
  const double coefficient_scale = std::abs(c0) + std::abs(c1) + std::abs(c2) + std::abs(c3);
  if (std::abs(c3) <= 1e-12 * coefficient_scale) {
    D0 = D2;  // the root is at infinity: D2 itself is degenerate
  } else {
    D0 = D1 + RealCubicRoot(c3, c2, c1, c0) * D2;
  }

  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(D0);
  if (eigen.info() != Eigen::Success) return 0;
  // Order the eigenvalues by magnitude: the smallest is the (near) zero one.
  int order[3] = {0, 1, 2};
  std::sort(order, order + 3, [&](int a, int b) {
    return std::abs(eigen.eigenvalues()(a)) < std::abs(eigen.eigenvalues()(b));
  });
  const double sigma_a = eigen.eigenvalues()(order[1]);
  const double sigma_b = eigen.eigenvalues()(order[2]);
  if (!(sigma_a * sigma_b < 0.0)) return 0;  // no real plane pair (a single line of solutions)
  const double sigma_pos = std::max(sigma_a, sigma_b), sigma_neg = std::min(sigma_a, sigma_b);
  const Eigen::Vector3d u_pos = eigen.eigenvectors().col(sigma_a > 0 ? order[1] : order[2]);
  const Eigen::Vector3d u_neg = eigen.eigenvectors().col(sigma_a > 0 ? order[2] : order[1]);

  Eigen::Vector3d depths[4];
  int num_depths = 0;
  for (const double sign : {1.0, -1.0}) {
    // Plane n . l = 0 with sqrt(s+) (u+ . l) = +-sqrt(-s-) (u- . l).
    const Eigen::Vector3d n = std::sqrt(sigma_pos) * u_pos - sign * std::sqrt(-sigma_neg) * u_neg;
    int k = 0;
    n.cwiseAbs().maxCoeff(&k);
    const int i = (k + 1) % 3, j = (k + 2) % 3;
    // l_k = w_i l_i + w_j l_j.
    const double w_i = -n(i) / n(k), w_j = -n(j) / n(k);
    const double a_ij = cn.A(i, j), a_ki = cn.A(k, i);
    const double b_ij = cn.B(i, j), b_ki = cn.B(k, i);
    // a_ij Q_ki - a_ki Q_ij = 0 as A l_i^2 + B l_i l_j + C l_j^2 = 0.
    const double A = a_ij * (w_i * w_i + 1.0 - 2.0 * b_ki * w_i) - a_ki;
    const double B = a_ij * (2.0 * w_i * w_j - 2.0 * b_ki * w_j) + 2.0 * a_ki * b_ij;
    const double C = a_ij * w_j * w_j - a_ki;
    const double discriminant = B * B - 4.0 * A * C;
    if (discriminant < 0.0) continue;
    const double root_disc = std::sqrt(discriminant);
    // Ratios (l_i : l_j) as homogeneous pairs, avoiding division by a small leading term.
    const double q = -0.5 * (B + std::copysign(root_disc, B));
    std::pair<double, double> ratios[2];
    int num_ratios = 0;
    if (q != 0.0) {
      // Roots t = l_i / l_j of A t^2 + B t + C: q / A and C / q, as (l_i, l_j) pairs.
      ratios[num_ratios++] = {q, A};
      ratios[num_ratios++] = {C, q};
    } else if (A != 0.0 || C != 0.0) {
      ratios[num_ratios++] = {0.0, 1.0};
      ratios[num_ratios++] = {1.0, 0.0};
    }
    for (int r = 0; r < num_ratios; ++r) {
      double li = ratios[r].first, lj = ratios[r].second;
      const double norm = std::hypot(li, lj);
      if (!(norm > 0.0)) continue;
      li /= norm;
      lj /= norm;
      const double q_ij = li * li + lj * lj - 2.0 * b_ij * li * lj;
      if (!(q_ij > 1e-300)) continue;
      double s = std::sqrt(a_ij / q_ij);
      if (li < 0 || (li == 0 && lj < 0)) s = -s;  // make the depths positive where possible
      Eigen::Vector3d l;
      l(i) = s * li;
      l(j) = s * lj;
      l(k) = w_i * l(i) + w_j * l(j);
      if (!l.allFinite()) continue;
      // Gauss-Newton on the three constraints (the factorization used only two of them).
      for (int it = 0; it < 5; ++it) {
        const Eigen::Vector3d f = cn.Residual(l);
        if (f.cwiseAbs().maxCoeff() < 1e-15) break;
        const Eigen::Matrix3d J = cn.Jacobian(l);
        const Eigen::FullPivLU<Eigen::Matrix3d> lu(J);
        if (!lu.isInvertible()) break;
        l -= lu.solve(f);
      }
      if (!l.allFinite() || (l.array() <= 0.0).any()) continue;
      if (cn.Residual(l).cwiseAbs().maxCoeff() > 1e-6) continue;
      bool duplicate = false;
      for (int d = 0; d < num_depths; ++d) duplicate |= (depths[d] - l).norm() < 1e-9;
      if (!duplicate && num_depths < 4) depths[num_depths++] = l;
    }
  }

  // Pose from the three camera-frame points Y_i = l_i x_i (metric again): R maps the world
  // triangle's frame onto the camera triangle's frame.
  Eigen::Matrix3d X_frame;
  X_frame << X01, X02, X_normal;
  const Eigen::Matrix3d X_frame_inverse = X_frame.inverse();
  for (int d = 0; d < num_depths; ++d) {
    const Eigen::Vector3d l = depths[d] * unit;
    const Eigen::Vector3d Y0 = l(0) * x[0], Y1 = l(1) * x[1], Y2 = l(2) * x[2];
    const Eigen::Vector3d Y01 = Y0 - Y1, Y02 = Y0 - Y2;
    Eigen::Matrix3d Y_frame;
    Y_frame << Y01, Y02, Y01.cross(Y02);
    const Eigen::Matrix3d R_raw = Y_frame * X_frame_inverse;
    // Nearest rotation (the raw matrix is orthonormal up to rounding).
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(R_raw, Eigen::ComputeFullU | Eigen::ComputeFullV);
    Eigen::Matrix3d R = svd.matrixU() * svd.matrixV().transpose();
    if (R.determinant() < 0) continue;
    Eigen::Quaterniond q(R);
    q.normalize();
    const Eigen::Vector3d t = Y0 - R * X[0];
    if (!t.allFinite() || !q.coeffs().allFinite()) continue;
    cam_from_world->emplace_back(q, t);
  }
  return static_cast<int>(cam_from_world->size());
}

}  // namespace lcv::slam
