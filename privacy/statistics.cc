#include "privacy/statistics.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>

#include "slam/util/error.h"

namespace lcv::privacy {

double ChiSquareUpperTail(double x, int dof) {
  LCV_CHECK(dof >= 1 && dof <= 5) << "dof " << dof;
  if (!(x > 0.0)) return 1.0;
  const double s = std::sqrt(x);
  const double e = std::exp(-0.5 * x);
  switch (dof) {
    case 1:
      return std::erfc(s / std::sqrt(2.0));
    case 2:
      return e;
    case 3:
      return std::erfc(s / std::sqrt(2.0)) + std::sqrt(2.0 / M_PI) * s * e;
    case 4:
      return e * (1.0 + 0.5 * x);
    default:  // 5
      return std::erfc(s / std::sqrt(2.0)) + std::sqrt(2.0 / M_PI) * s * e * (1.0 + x / 3.0);
  }
}

double KolmogorovUpperTail(double lambda) {
  if (lambda < 0.2) return 1.0;
  double sum = 0.0;
  for (int k = 1; k <= 100; ++k) {
    const double term = std::exp(-2.0 * k * k * lambda * lambda);
    sum += (k % 2 == 1 ? 2.0 : -2.0) * term;
    if (term < 1e-16) break;
  }
  return std::clamp(sum, 0.0, 1.0);
}

KsResult KolmogorovSmirnovUniform(std::vector<double> samples, double lo, double hi) {
  KsResult out;
  out.count = static_cast<int>(samples.size());
  if (samples.empty() || !(hi > lo)) return out;
  std::sort(samples.begin(), samples.end());
  const double n = static_cast<double>(samples.size());
  double d = 0.0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const double u = std::clamp((samples[i] - lo) / (hi - lo), 0.0, 1.0);
    d = std::max({d, (i + 1) / n - u, u - i / n});
  }
  out.statistic = d;
  const double sqrt_n = std::sqrt(n);
  // Stephens' correction makes the asymptotic tail accurate down to n ~ 5.
  out.p_value = KolmogorovUpperTail((sqrt_n + 0.12 + 0.11 / sqrt_n) * d);
  return out;
}

SphereTestResult RayleighTest(const std::vector<Eigen::Vector3d>& directions) {
  SphereTestResult out;
  out.count = static_cast<int>(directions.size());
  if (directions.empty()) return out;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& d : directions) sum += d;
  const double n = static_cast<double>(directions.size());
  out.statistic = 3.0 * sum.squaredNorm() / n;
  out.p_value = ChiSquareUpperTail(out.statistic, 3);
  return out;
}

SphereTestResult BinghamTest(const std::vector<Eigen::Vector3d>& directions) {
  SphereTestResult out;
  out.count = static_cast<int>(directions.size());
  if (directions.empty()) return out;
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& d : directions) scatter.noalias() += d * d.transpose();
  const double n = static_cast<double>(directions.size());
  scatter /= n;
  const Eigen::Vector3d lambda = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(scatter).eigenvalues();
  out.statistic = 7.5 * n * (lambda.array() - 1.0 / 3.0).square().sum();
  out.p_value = ChiSquareUpperTail(out.statistic, 5);
  return out;
}

double Median(std::vector<double> values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const std::size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  if (values.size() % 2 == 1) return values[mid];
  const double upper = values[mid];
  const double lower = *std::max_element(values.begin(), values.begin() + mid);
  if (std::isinf(upper)) return upper;
  return 0.5 * (lower + upper);
}

double Quantile(std::vector<double> values, double q) {
  LCV_CHECK(!values.empty());
  std::sort(values.begin(), values.end());
  const double pos = std::clamp(q, 0.0, 1.0) * (values.size() - 1);
  const std::size_t i = static_cast<std::size_t>(std::floor(pos));
  const std::size_t j = std::min(values.size() - 1, i + 1);
  return values[i] + (pos - i) * (values[j] - values[i]);
}

}  // namespace lcv::privacy
