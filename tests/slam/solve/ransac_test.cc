#include "slam/solve/ransac.h"

#include <random>

#include <gtest/gtest.h>

namespace lcv::slam {
namespace {

// y = a x + b, residual the vertical distance.
struct Line {
  double a = 0, b = 0;
};

class LineEstimator {
 public:
  using Model = Line;
  static constexpr int kMinNumSamples = 2;
  LineEstimator(const std::vector<double>& x, const std::vector<double>& y) : x_(x), y_(y) {}
  int NumData() const { return static_cast<int>(x_.size()); }
  void Estimate(const std::vector<int>& sample, std::vector<Model>* models) const {
    models->clear();
    const double dx = x_[sample[1]] - x_[sample[0]];
    if (std::abs(dx) < 1e-12) return;  // degenerate: vertical
    Line line;
    line.a = (y_[sample[1]] - y_[sample[0]]) / dx;
    line.b = y_[sample[0]] - line.a * x_[sample[0]];
    models->push_back(line);
  }
  void Residuals(const Model& line, std::vector<double>* r2) const {
    r2->resize(x_.size());
    for (size_t i = 0; i < x_.size(); ++i) {
      const double r = y_[i] - (line.a * x_[i] + line.b);
      (*r2)[i] = r * r;
    }
  }

 protected:
  const std::vector<double>& x_;
  const std::vector<double>& y_;
};

// The same with least-squares refinement (LO-RANSAC hook).
class RefiningLineEstimator : public LineEstimator {
 public:
  using LineEstimator::LineEstimator;
  mutable int refine_calls = 0;
  bool Refine(const std::vector<int>& inliers, Model* line) const {
    ++refine_calls;
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    const double n = static_cast<double>(inliers.size());
    for (int i : inliers) {
      sx += x_[i];
      sy += y_[i];
      sxx += x_[i] * x_[i];
      sxy += x_[i] * y_[i];
    }
    const double det = n * sxx - sx * sx;
    if (std::abs(det) < 1e-12) return false;
    line->a = (n * sxy - sx * sy) / det;
    line->b = (sy - line->a * sx) / n;
    return true;
  }
};

struct LineData {
  std::vector<double> x, y;
  std::vector<char> is_inlier;
};

LineData MakeLineData(std::uint64_t seed, int n, double outlier_ratio, double noise) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(-10, 10);
  std::normal_distribution<double> normal(0, noise);
  LineData data;
  for (int i = 0; i < n; ++i) {
    const double x = uniform(rng);
    const bool outlier = i < outlier_ratio * n;
    data.x.push_back(x);
    data.y.push_back(outlier ? uniform(rng) * 5.0 : 2.0 * x - 1.0 + normal(rng));
    data.is_inlier.push_back(!outlier);
  }
  return data;
}

TEST(Ransac, FitsLineWithHalfOutliers) {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const LineData data = MakeLineData(seed, 200, 0.5, 0.01);
    RansacOptions options;
    options.max_error = 0.05;
    options.random_seed = seed;
    const RansacReport<Line> report = Ransac(options, LineEstimator(data.x, data.y));
    ASSERT_TRUE(report.success);
    EXPECT_NEAR(report.model.a, 2.0, 0.02);
    EXPECT_NEAR(report.model.b, -1.0, 0.05);
    int agree = 0;
    for (int i = 0; i < 200; ++i) agree += report.inlier_mask[i] == data.is_inlier[i];
    EXPECT_GE(agree, 196);  // a random outlier may fall on the line
    EXPECT_GT(report.num_trials, 0);
    EXPECT_LE(report.num_trials, options.max_num_trials);
  }
}

TEST(Ransac, AdaptiveTrialCountStopsEarlyOnCleanData) {
  const LineData data = MakeLineData(4, 100, 0.0, 0.001);
  RansacOptions options;
  options.max_error = 0.01;
  options.max_num_trials = 10000;
  const RansacReport<Line> report = Ransac(options, LineEstimator(data.x, data.y));
  ASSERT_TRUE(report.success);
  EXPECT_LT(report.num_trials, 10);
  EXPECT_EQ(report.num_inliers, 100);
}

TEST(Ransac, StopsWhenAskedAndKeepsTheBestModelSoFar) {
  // 80% outliers and a clean-data threshold: the adaptive count wants thousands of trials.
  const LineData data = MakeLineData(6, 200, 0.8, 0.001);
  RansacOptions options;
  options.max_error = 0.01;
  options.max_num_trials = 5000;
  options.random_seed = 6;
  const RansacReport<Line> full = Ransac(options, LineEstimator(data.x, data.y));
  ASSERT_TRUE(full.success);
  EXPECT_FALSE(full.stopped_early);
  ASSERT_GT(full.num_trials, 60);

  int asked = 0;
  options.should_stop = [&asked] { return ++asked >= 50; };
  const RansacReport<Line> cut = Ransac(options, LineEstimator(data.x, data.y));
  EXPECT_TRUE(cut.stopped_early);
  EXPECT_EQ(cut.num_trials, 50);
  EXPECT_EQ(asked, 50);
  // The same seed draws the same samples: 50 trials of that sequence were enough for a model
  // here (inlier ratio 0.2 -> 1 - 0.96^50 = 87% chance), and it is the true line.
  ASSERT_TRUE(cut.success);
  EXPECT_NEAR(cut.model.a, 2.0, 0.01);
  EXPECT_EQ(cut.inlier_mask.size(), data.x.size());

  // Asked at once: one trial, and a report whose success says whether it found the line.
  options.should_stop = [] { return true; };
  const RansacReport<Line> first = Ransac(options, LineEstimator(data.x, data.y));
  EXPECT_TRUE(first.stopped_early);
  EXPECT_EQ(first.num_trials, 1);
}

TEST(Ransac, RequiredTrialsMatchesFormula) {
  // w = 0.5, s = 2, p = 0.99: log(0.01) / log(0.75) = 16.008 -> 17.
  EXPECT_EQ(RequiredRansacTrials(0.5, 2, 0.99, 1000), 17);
  EXPECT_EQ(RequiredRansacTrials(1.0, 5, 0.99, 1000), 1);
  EXPECT_EQ(RequiredRansacTrials(0.0, 5, 0.99, 1000), 1000);
  EXPECT_EQ(RequiredRansacTrials(0.01, 8, 0.99, 1000), 1000);
}

TEST(Ransac, DeterministicForSeed) {
  const LineData data = MakeLineData(5, 150, 0.4, 0.02);
  RansacOptions options;
  options.max_error = 0.06;
  options.random_seed = 77;
  const auto a = Ransac(options, LineEstimator(data.x, data.y));
  const auto b = Ransac(options, LineEstimator(data.x, data.y));
  EXPECT_EQ(a.num_trials, b.num_trials);
  EXPECT_EQ(a.model.a, b.model.a);
  EXPECT_EQ(a.model.b, b.model.b);
  EXPECT_EQ(a.inlier_mask, b.inlier_mask);
}

TEST(Ransac, LocalOptimizationImprovesModel) {
  const LineData data = MakeLineData(6, 400, 0.3, 0.05);
  RansacOptions options;
  options.max_error = 0.15;
  options.random_seed = 3;
  options.local_optimization = false;
  const auto plain = Ransac(options, LineEstimator(data.x, data.y));
  options.local_optimization = true;
  const RefiningLineEstimator refining(data.x, data.y);
  const auto lo = Ransac(options, refining);
  ASSERT_TRUE(plain.success);
  ASSERT_TRUE(lo.success);
  EXPECT_GT(refining.refine_calls, 0);
  EXPECT_LE(lo.score, plain.score);
  EXPECT_NEAR(lo.model.a, 2.0, 0.005);
}

TEST(Ransac, FailsOnTooFewDataAndPureNoise) {
  std::vector<double> x = {1.0}, y = {1.0};
  RansacOptions options;
  options.max_error = 0.1;
  EXPECT_FALSE(Ransac(options, LineEstimator(x, y)).success);

  const LineData noise = MakeLineData(7, 100, 1.0, 0.0);
  options.max_error = 0.001;
  options.min_inlier_ratio = 0.2;
  const auto report = Ransac(options, LineEstimator(noise.x, noise.y));
  EXPECT_FALSE(report.success);
  EXPECT_EQ(report.num_trials, options.max_num_trials);
}

TEST(Ransac, RejectsBadOptions) {
  RansacOptions options;  // max_error 0
  EXPECT_TRUE(options.Problem().has_value());
  std::vector<double> x = {1, 2, 3}, y = {1, 2, 3};
  EXPECT_THROW(Ransac(options, LineEstimator(x, y)), std::logic_error);
  options.max_error = 1.0;
  options.confidence = 1.0;
  EXPECT_TRUE(options.Problem().has_value());
}

}  // namespace
}  // namespace lcv::slam
