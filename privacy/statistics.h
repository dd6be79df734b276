#pragma once
// Distribution functions and goodness-of-fit tests used by the randomness and format checks.
// All p-values are upper-tail probabilities under the null hypothesis (small = reject).

#include <vector>

#include <Eigen/Core>

namespace lcv::privacy {

// P(chi2_k >= x) for k = 1..5 degrees of freedom (closed forms; precondition 1 <= k <= 5).
double ChiSquareUpperTail(double x, int dof);

// Asymptotic Kolmogorov distribution: P(K >= lambda), with the usual small-sample correction
// applied by KolmogorovSmirnovUniform.
double KolmogorovUpperTail(double lambda);

struct KsResult {
  double statistic = 0.0;  // sup |F_n(u) - F(u)|
  double p_value = 1.0;
  int count = 0;
};
// One-sample Kolmogorov-Smirnov test of samples against Uniform(lo, hi). Sorts a copy.
KsResult KolmogorovSmirnovUniform(std::vector<double> samples, double lo, double hi);

// Tests of uniformity of unit vectors on the sphere (Mardia & Jupp, "Directional Statistics",
// 10.4 and 10.7). Both are asymptotically chi-square under uniformity.
struct SphereTestResult {
  double statistic = 0.0;
  double p_value = 1.0;
  int count = 0;
};
// Rayleigh test: 3 n |mean d|^2 ~ chi2_3. Detects a preferred (signed) direction.
SphereTestResult RayleighTest(const std::vector<Eigen::Vector3d>& directions);
// Bingham test for axial data (d ~ -d): (15 n / 2) sum_i (lambda_i - 1/3)^2 ~ chi2_5, lambda the
// eigenvalues of the scatter matrix (1/n) sum d d^T. Detects concentration around an axis or a
// great circle, the signature of directions tied to planes.
SphereTestResult BinghamTest(const std::vector<Eigen::Vector3d>& directions);

// Median of a copy (NaN for an empty input); infinities sort last.
double Median(std::vector<double> values);
// q in [0, 1], linear interpolation between order statistics. Precondition: non-empty.
double Quantile(std::vector<double> values, double q);

}  // namespace lcv::privacy
