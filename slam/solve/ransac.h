#pragma once
// Generic RANSAC over a minimal solver (COLMAP optim/ransac.h, PoseLib robust/ransac.h), with
// MSAC scoring, an adaptive trial count and an optional local-optimization (LO-RANSAC) step.
//
// An Estimator is a small object that holds (pointers to) the data and provides:
//
//   using Model = ...;                            // e.g. Rigid3d, Eigen::Matrix3d
//   static constexpr int kMinNumSamples = ...;    // size of a minimal sample
//   int NumData() const;                          // number of correspondences
//   // Models consistent with the minimal sample (indices into the data); clears *models first.
//   void Estimate(const std::vector<int>& sample, std::vector<Model>* models) const;
//   // Squared residual of every datum under model, in the units of RansacOptions::max_error
//   // squared; resizes *squared_residuals to NumData().
//   void Residuals(const Model& model, std::vector<double>* squared_residuals) const;
//
// and optionally, for LO-RANSAC (used when RansacOptions::local_optimization is set):
//
//   // Improves *model from the indices of its inliers (non-minimal solve and/or a few
//   // Gauss-Newton steps). Returns false when it could not; *model is then left unchanged.
//   bool Refine(const std::vector<int>& inliers, Model* model) const;
//
// Scoring: MSAC, sum_i min(r_i^2, max_error^2); the inliers are the data with
// r_i^2 <= max_error^2. The trial count adapts to the best inlier ratio w found so far:
//   N = log(1 - confidence) / log(1 - w^kMinNumSamples),
// clamped to [min_num_trials, max_num_trials].
//
// Deterministic: the samples come from a std::mt19937_64 seeded with RansacOptions::random_seed,
// so the same data and options give the same result. No logging, no exceptions for data
// problems (a degenerate sample simply yields no model). Not thread-safe across a shared
// estimator only if the estimator itself is not (all of ours are const and reentrant).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <random>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "slam/util/error.h"

namespace lcv::slam {

struct RansacOptions {
  // Inlier threshold on the residual (not squared), in the estimator's units; for the bearing
  // estimators of this folder an angle in radians (about pixels / focal length).
  double max_error = 0.0;
  // A result is a success only when at least this fraction of the data are inliers.
  double min_inlier_ratio = 0.1;
  // Probability that at least one sample was outlier-free when the loop stops.
  double confidence = 0.999;
  int min_num_trials = 0;
  int max_num_trials = 1000;
  std::uint64_t random_seed = 0;
  // Run Estimator::Refine on the inliers of every new best model (if the estimator has it) and
  // once more on the final model.
  bool local_optimization = true;
  // Asked after every trial: true stops the sampling there, and the best model so far gets the
  // final refinement as usual (RansacReport::stopped_early). For a caller with a deadline (the
  // line-cloud check of a live camera, slam/tracking.h); empty: never asked. A deadline makes
  // the result depend on the machine's speed, so deterministic callers leave it empty.
  std::function<bool()> should_stop;

  // Empty when usable, else what is wrong ("max_error must be > 0").
  std::optional<std::string> Problem() const {
    if (!(max_error > 0.0)) return "max_error must be > 0";
    if (!(min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0))
      return "min_inlier_ratio must be in [0, 1]";
    if (!(confidence > 0.0 && confidence < 1.0)) return "confidence must be in (0, 1)";
    if (min_num_trials < 0) return "min_num_trials must be >= 0";
    if (max_num_trials < 1 || max_num_trials < min_num_trials)
      return "max_num_trials must be >= max(1, min_num_trials)";
    return std::nullopt;
  }
  // Throws std::logic_error naming the problem (options are set by code; configs are validated
  // by mapping/io before they get here).
  void Check() const {
    const auto problem = Problem();
    LCV_CHECK(!problem) << *problem;
  }
};

template <typename Model>
struct RansacReport {
  bool success = false;
  int num_trials = 0;
  int num_inliers = 0;
  bool stopped_early = false;  // RansacOptions::should_stop ended the sampling
  double score = std::numeric_limits<double>::infinity();  // MSAC cost of the model, lower better
  std::vector<char> inlier_mask;  // one per datum when success, 1 = inlier
  Model model{};
};

// Number of trials needed so that, with probability `confidence`, one sample of size
// num_samples drawn from data with inlier ratio `inlier_ratio` is outlier-free.
inline int RequiredRansacTrials(double inlier_ratio, int num_samples, double confidence,
                                int max_num_trials) {
  if (inlier_ratio <= 0.0) return max_num_trials;
  const double all_inliers = std::pow(inlier_ratio, num_samples);
  if (all_inliers >= 1.0 - 1e-12) return 1;
  const double denominator = std::log1p(-all_inliers);
  if (denominator >= 0.0) return max_num_trials;
  const double n = std::ceil(std::log1p(-confidence) / denominator);
  if (!(n < static_cast<double>(max_num_trials))) return max_num_trials;
  return std::max(1, static_cast<int>(n));
}

namespace internal {

template <typename E, typename = void>
struct HasRefine : std::false_type {};
template <typename E>
struct HasRefine<E, std::void_t<decltype(std::declval<const E&>().Refine(
                        std::declval<const std::vector<int>&>(),
                        std::declval<typename E::Model*>()))>> : std::true_type {};

// MSAC cost and inlier count of squared residuals against squared threshold.
inline std::pair<double, int> MsacScore(const std::vector<double>& squared_residuals,
                                        double max_error_sq) {
  double cost = 0.0;
  int inliers = 0;
  for (const double r2 : squared_residuals) {
    if (r2 <= max_error_sq) {
      cost += r2;
      ++inliers;
    } else {
      cost += max_error_sq;
    }
  }
  return {cost, inliers};
}

inline void InlierIndices(const std::vector<double>& squared_residuals, double max_error_sq,
                          std::vector<int>* indices) {
  indices->clear();
  for (int i = 0; i < static_cast<int>(squared_residuals.size()); ++i) {
    if (squared_residuals[i] <= max_error_sq) indices->push_back(i);
  }
}

}  // namespace internal

// Runs RANSAC. Precondition: options.Check() passes. Returns success == false when there are
// fewer data than a minimal sample or no model reaches min_inlier_ratio (and at least
// kMinNumSamples inliers).
template <typename Estimator>
RansacReport<typename Estimator::Model> Ransac(const RansacOptions& options,
                                               const Estimator& estimator) {
  using Model = typename Estimator::Model;
  constexpr int kSamples = Estimator::kMinNumSamples;
  options.Check();

  RansacReport<Model> report;
  const int num_data = estimator.NumData();
  if (num_data < kSamples) return report;

  const double max_error_sq = options.max_error * options.max_error;
  std::mt19937_64 rng(options.random_seed);
  std::vector<int> sample(kSamples);
  std::vector<Model> models;
  std::vector<double> residuals;
  std::vector<int> inliers;

  Model best_model{};
  double best_cost = std::numeric_limits<double>::infinity();
  int best_inliers = 0;
  bool have_model = false;

  // Keeps a model (and its LO refinement) when it beats the best one so far.
  auto consider = [&](const Model& model) {
    estimator.Residuals(model, &residuals);
    auto [cost, count] = internal::MsacScore(residuals, max_error_sq);
    if (cost >= best_cost) return;
    best_model = model;
    best_cost = cost;
    best_inliers = count;
    have_model = true;
    if constexpr (internal::HasRefine<Estimator>::value) {
      if (options.local_optimization && count >= kSamples) {
        internal::InlierIndices(residuals, max_error_sq, &inliers);
        Model refined = model;
        if (estimator.Refine(inliers, &refined)) {
          estimator.Residuals(refined, &residuals);
          auto [refined_cost, refined_count] = internal::MsacScore(residuals, max_error_sq);
          if (refined_cost < best_cost) {
            best_model = refined;
            best_cost = refined_cost;
            best_inliers = refined_count;
          }
        }
      }
    }
  };

  int max_trials = options.max_num_trials;
  int trial = 0;
  for (; trial < max_trials; ++trial) {
    // Sample kSamples distinct indices (partial Fisher-Yates would need an O(n) buffer; with
    // kSamples << n, rejection of duplicates is cheaper).
    for (int k = 0; k < kSamples; ++k) {
      for (;;) {
        const int candidate = static_cast<int>(
            std::uniform_int_distribution<int>(0, num_data - 1)(rng));
        bool duplicate = false;
        for (int j = 0; j < k; ++j) duplicate |= sample[j] == candidate;
        if (!duplicate) {
          sample[k] = candidate;
          break;
        }
      }
    }
    estimator.Estimate(sample, &models);
    for (const Model& model : models) consider(model);

    if (have_model) {
      const double ratio = static_cast<double>(best_inliers) / num_data;
      const int needed = RequiredRansacTrials(ratio, kSamples, options.confidence,
                                              options.max_num_trials);
      max_trials = std::max(options.min_num_trials, std::min(needed, options.max_num_trials));
    }
    if (options.should_stop && trial + 1 < max_trials && options.should_stop()) {
      report.stopped_early = true;
      ++trial;
      break;
    }
  }
  report.num_trials = trial;
  if (!have_model) return report;

  // Final polish on all inliers of the best model.
  if constexpr (internal::HasRefine<Estimator>::value) {
    if (options.local_optimization && best_inliers >= kSamples) {
      estimator.Residuals(best_model, &residuals);
      internal::InlierIndices(residuals, max_error_sq, &inliers);
      Model refined = best_model;
      if (estimator.Refine(inliers, &refined)) {
        estimator.Residuals(refined, &residuals);
        auto [cost, count] = internal::MsacScore(residuals, max_error_sq);
        if (cost <= best_cost) {
          best_model = refined;
          best_cost = cost;
          best_inliers = count;
        }
      }
    }
  }

  estimator.Residuals(best_model, &residuals);
  report.inlier_mask.assign(num_data, 0);
  int count = 0;
  for (int i = 0; i < num_data; ++i) {
    if (residuals[i] <= max_error_sq) {
      report.inlier_mask[i] = 1;
      ++count;
    }
  }
  report.model = best_model;
  report.num_inliers = count;
  report.score = best_cost;
  report.success =
      count >= kSamples && static_cast<double>(count) >= options.min_inlier_ratio * num_data;
  return report;
}

}  // namespace lcv::slam
