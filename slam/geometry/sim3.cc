#include "slam/geometry/sim3.h"

#include <cmath>

namespace lcv::slam {
namespace {

// The matrix W with translation = W * v in the Sim(3) exponential: with Omega = [omega]x,
//   W = sum_k (Omega + sigma I)^k / (k + 1)! = integral_0^1 exp(sigma s) exp(s Omega) ds
//     = A Omega + B Omega^2 + C I,
//   A = int e^(sigma s) sin(s theta) / theta ds,  B = int e^(sigma s) (1 - cos(s theta)) / theta^2 ds,
//   C = int e^(sigma s) ds = (e^sigma - 1) / sigma.
// The closed forms (Strasdat's thesis; Sophus' sim_details.hpp) cancel catastrophically when
// theta and sigma are both small (errors up to 1e-8 near 1e-8 rad, and C = 1 was assumed for
// |sigma| < 1e-8), so there the integrals are taken by 8-point Gauss-Legendre quadrature, exact to
// rounding for max(theta, |sigma|) < 1 since the integrands are entire with small derivatives.
Eigen::Matrix3d SimilarityW(const Eigen::Vector3d& omega, double sigma) {
  const double theta = omega.norm();
  const Eigen::Matrix3d W1 = SkewSymmetric(omega);
  const Eigen::Matrix3d W2 = W1 * W1;
  double A = 0.0, B = 0.0, C = 0.0;
  if (theta < 1.0 && std::abs(sigma) < 1.0) {
    // Nodes and weights on [-1, 1].
    static constexpr double kNodes[4] = {0.1834346424956498, 0.5255324099163290,
                                         0.7966664774136267, 0.9602898564975363};
    static constexpr double kWeights[4] = {0.3626837833783620, 0.3137066458778873,
                                           0.2223810344533745, 0.1012285362903763};
    // sin(x) / x, accurate for all x.
    const auto sinc = [](double x) {
      return std::abs(x) < 1e-4 ? 1.0 - x * x / 6.0 : std::sin(x) / x;
    };
    for (int i = 0; i < 4; ++i) {
      for (const double sign : {-1.0, 1.0}) {
        const double s = 0.5 * (1.0 + sign * kNodes[i]);  // node on [0, 1]
        const double weight = 0.5 * kWeights[i] * std::exp(sigma * s);
        const double half_sinc = sinc(0.5 * s * theta);
        A += weight * s * sinc(s * theta);
        B += weight * 0.5 * s * s * half_sinc * half_sinc;  // (1 - cos x) = 2 sin^2(x / 2)
        C += weight;
      }
    }
  } else {
    // Here theta >= 1 or |sigma| >= 1: the remaining cancellations cost at most a few ulps of W.
    const double scale = std::exp(sigma);
    C = sigma == 0.0 ? 1.0 : std::expm1(sigma) / sigma;
    const double t2 = theta * theta;
    if (theta < 1e-12) {  // the theta^2 terms are far below rounding; avoids 1 / 0
      const double s2 = sigma * sigma;
      A = ((sigma - 1.0) * scale + 1.0) / s2;
      B = (scale * 0.5 * s2 + scale - 1.0 - sigma * scale) / (s2 * sigma);
    } else if (sigma == 0.0) {
      const double sin_half = std::sin(0.5 * theta);
      A = 2.0 * sin_half * sin_half / t2;
      B = (theta - std::sin(theta)) / (t2 * theta);
    } else {
      const double a = scale * std::sin(theta);
      const double b = scale * std::cos(theta);
      const double c = t2 + sigma * sigma;
      A = (a * sigma + (1.0 - b) * theta) / (theta * c);
      B = (C - ((b - 1.0) * sigma + a * theta) / c) / t2;
    }
  }
  return A * W1 + B * W2 + C * Eigen::Matrix3d::Identity();
}

}  // namespace

Sim3d Sim3d::Exp(const Vector7d& delta) {
  const Eigen::Vector3d v = delta.head<3>();
  const Eigen::Vector3d omega = delta.segment<3>(3);
  const double sigma = delta(6);
  return Sim3d(std::exp(sigma), ExpSO3(omega), SimilarityW(omega, sigma) * v);
}

Vector7d Sim3d::Log() const {
  Vector7d out;
  const Eigen::Vector3d omega = LogSO3(rotation);
  const double sigma = std::log(scale);
  out.head<3>() = SimilarityW(omega, sigma).partialPivLu().solve(translation);
  out.segment<3>(3) = omega;
  out(6) = sigma;
  return out;
}

Rigid3d TransformPose(const Sim3d& world2_from_world1, const Rigid3d& cam_from_world1) {
  // x_cam (in world2 units) = s * (Rc * x1 + tc), x1 = R^T (x2 - t) / s.
  const Eigen::Quaterniond rotation = cam_from_world1.rotation * world2_from_world1.rotation.conjugate();
  const Eigen::Vector3d translation = world2_from_world1.scale * cam_from_world1.translation -
                                      rotation * world2_from_world1.translation;
  return Rigid3d(rotation.normalized(), translation);
}

}  // namespace lcv::slam
