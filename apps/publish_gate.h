#pragma once
// The publishing gate (docs/curation.md "Publishing gate"), shared by `lcv map publish` and
// `lcv demo`: a point map is converted to a line cloud (coincident points merged first), audited
// against its own hidden points under risk limits, and while a limit fails, lines are dropped
// (by default those whose hidden point a failing limit's attack recovers, never below a
// per-server-keyframe coverage; privacy/coverage_mitigation.h) until the limits hold or the
// budget (max_drop) is spent. The caller decides what to write: publish `lines` only when
// `audit.passed`.
//
// Thread safety: none needed (no shared state); the audit uses options.audit.num_threads.

#include <cstddef>
#include <cstdint>
#include <ostream>
#include <string>

#include <nlohmann/json.hpp>

#include "privacy/audit.h"
#include "privacy/coverage_mitigation.h"
#include "slam/data/map.h"

namespace lcv::apps {

enum class PublishOrder {
  kRecovered,  // the lines the failing limits' attacks recover first, with the coverage guard
  kRisk,       // the earlier mitigation: --step per round, riskiest by the attacks' score
};

struct PublishGateOptions {
  privacy::AuditOptions audit;  // fail_rules: the limits (e.g. privacy::kDefaultFailRules)
  std::uint64_t seed = 0;       // of the line directions
  PublishOrder order = PublishOrder::kRecovered;
  privacy::KeyframeCoverageOptions coverage;  // min_lines_per_keyframe 0: no guard
  double step = 0.1;      // largest share of the remaining lines dropped per round, (0, 1)
  double max_drop = 0.8;  // largest share of the lines dropped in total, [0, 1)
};

struct PublishGateResult {
  slam::Map lines;              // the line cloud after the last round
  privacy::AuditReport audit;   // of `lines`; passed: safe to publish under the limits
  std::string verdict;          // why the limits still fail (empty when passed)
  std::size_t converted_lines = 0;
  int coincident_points_merged = 0;
  int keyframes_with_12_lines_before = 0;  // p6L's minimum inliers: a localization-cost proxy
  int keyframes_with_12_lines_after = 0;
  privacy::KeyframeCoverageStats coverage_before;
  privacy::KeyframeCoverageStats coverage_after;
  int lines_dropped_breaking_coverage = 0;
  nlohmann::json rounds;  // per round: lines, dropped_fraction, passed, attacks, lines_dropped...
};

// Per-attack summary of an audit for reports: name, mean_risk, passed (null without a rule),
// recovered fractions by tolerance.
nlohmann::json AttackSummary(const privacy::AuditReport& report);

// Runs the gate on a point map with hidden points (its points); progress (may be null) gets a
// line per round. Precondition: points.points is not empty (checked).
PublishGateResult RunPublishGate(const slam::Map& points, const PublishGateOptions& options,
                                 std::ostream* progress);

}  // namespace lcv::apps
