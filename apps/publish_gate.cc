#include "apps/publish_gate.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

#include "mapping/line_cloud.h"
#include "privacy/mitigation.h"
#include "slam/util/error.h"

namespace lcv::apps {

using nlohmann::json;

namespace {

// Server keyframes that still see at least min_lines lines: the share of views in which p6L
// (which needs 12 inliers by default) can localize at all. A proxy of the localization cost;
// `lcv localize` measures the real one on a client sequence.
int KeyframesWithLines(const slam::Map& map, int min_lines) {
  int count = 0;
  for (const auto& [id, kf] : map.server_keyframes) {
    count += static_cast<int>(kf.line_ids.size()) >= min_lines;
  }
  return count;
}

}  // namespace

json AttackSummary(const privacy::AuditReport& report) {
  json out = json::array();
  for (const auto& a : report.attacks) {
    json item{{"name", a.result.name}, {"mean_risk", a.mean_risk}};
    item["passed"] = a.within_limits ? json(*a.within_limits) : json(nullptr);
    if (a.recovery) {
      for (std::size_t k = 0; k < a.recovery->tolerances.size(); ++k) {
        item["recovered"][a.recovery->tolerances[k].Label()] = a.recovery->fractions[k];
      }
    }
    out.push_back(item);
  }
  return out;
}

PublishGateResult RunPublishGate(const slam::Map& points, const PublishGateOptions& options,
                                 std::ostream* progress) {
  LCV_CHECK(!points.points.empty()) << "a point map to publish";
  mapping::LineCloudOptions convert;
  convert.seed = options.seed;
  PublishGateResult result;
  mapping::LineCloudReport conversion;
  slam::Map lines = mapping::ConvertToLineCloud(points, convert, &conversion);
  result.coincident_points_merged = conversion.points_merged_away;
  const std::size_t converted_lines = lines.lines.size();
  result.converted_lines = converted_lines;
  const slam::Map converted = lines;  // the direction reference of the mitigation
  result.keyframes_with_12_lines_before = KeyframesWithLines(lines, 12);
  std::map<slam::Id, Eigen::Vector3d> hidden_points;  // from the first audit
  const privacy::KeyframeCoverageOptions& coverage = options.coverage;
  const bool guard = options.order == PublishOrder::kRecovered && coverage.min_lines_per_keyframe > 0;
  const double step = options.step;
  const double max_drop = options.max_drop;
  int& dropped_protected = result.lines_dropped_breaking_coverage;
  json& rounds = result.rounds;
  rounds = json::array();
  privacy::AuditReport& audit = result.audit;
  std::string& verdict = result.verdict;
  for (int round = 0;; ++round) {
    privacy::AuditInputs inputs;
    inputs.map = &lines;
    inputs.reference = &points;
    audit = privacy::RunAudit(inputs, options.audit, nullptr);
    if (round == 0) {
      hidden_points = privacy::HiddenPointsOf(audit);
      result.coverage_before = privacy::MeasureKeyframeCoverage(lines, hidden_points, coverage);
    }
    const double dropped = 1.0 - static_cast<double>(lines.lines.size()) / converted_lines;
    rounds.push_back(json{{"round", round},
                          {"lines", lines.lines.size()},
                          {"dropped_fraction", dropped},
                          {"passed", audit.passed},
                          {"attacks", AttackSummary(audit)}});
    if (progress != nullptr) {
      *progress << "publish gate: round " << round << ": " << lines.lines.size() << " lines ("
                << static_cast<int>(std::lround(100.0 * dropped)) << "% dropped), audit "
                << (audit.passed ? "passed" : "failed") << "\n";
    }
    if (audit.passed) break;
    // Only the attack limits and duplicate pairs can be mended by dropping lines.
    std::string unfixable;
    for (const auto& c : audit.checks) {
      if (!c.passed && c.name != "thresholds" && c.name != "duplicates") unfixable = c.name;
    }
    if (!unfixable.empty()) {
      verdict = "check '" + unfixable + "' failed; dropping lines cannot fix it";
      break;
    }
    // Lines that may still go within --max-drop. The risk order drops whole --step rounds; the
    // recovered order drops at most the excess per round, so it may use the remainder.
    const int allowance =
        static_cast<int>(std::floor(max_drop * static_cast<double>(converted_lines) + 1e-9)) -
        static_cast<int>(converted_lines - lines.lines.size());
    const double next_drop = 1.0 - (1.0 - dropped) * (1.0 - step);
    if (options.order == PublishOrder::kRisk ? next_drop > max_drop + 1e-9 : allowance <= 0) {
      verdict = "the limits still fail after dropping " + std::to_string(dropped) +
                " of the lines (--max-drop " + std::to_string(max_drop) + ")";
      break;
    }
    std::vector<privacy::LineAttackResult> attacks;
    for (const auto& a : audit.attacks) attacks.push_back(a.result);
    const int round_budget =
        static_cast<int>(std::floor(step * static_cast<double>(lines.lines.size()) + 1e-9));
    if (options.order == PublishOrder::kRisk) {
      privacy::MitigationOptions mitigate;
      mitigate.mode = privacy::MitigationMode::kDrop;
      mitigate.fraction = step;
      mitigate.seed = convert.seed + 1 + round;
      privacy::MitigationReport mitigated;
      lines = privacy::MitigateRiskiestLines(lines, privacy::CombineRisks(attacks), {}, mitigate,
                                             &mitigated);
      mapping::ReapplyInformationRule(convert, &lines);
      rounds.back()["lines_dropped"] = mitigated.num_changed;
      continue;
    }
    privacy::CoverageDropOptions drop;
    drop.coverage = coverage;
    drop.guard = guard;
    drop.max_lines = round_budget;
    drop.direction_reference = &converted;
    drop.first_tier_priority = privacy::kRecoveredPriority;
    int excess = 0;
    const std::map<slam::Id, double> priority =
        privacy::RecoveredFirstPriority(audit, options.audit.fail_rules, &excess);
    // Each dropped recovered line removes its own recovered point (and thins its neighbours'
    // support): dropping the excess may already meet the limits, so no more than that per
    // round; the next audit measures what the thinning did. Duplicate pairs (the duplicates
    // check) have no recovered fraction: then the --step budget.
    if (excess > 0) drop.max_lines = std::min(drop.max_lines, excess);
    drop.max_lines = std::min(std::max(drop.max_lines, 1), allowance);
    privacy::CoverageDropReport dropped_report;
    slam::Map mitigated = privacy::DropWithKeyframeCoverage(lines, priority, hidden_points, drop,
                                                            &dropped_report);
    if (dropped_report.num_dropped == 0 && dropped_report.num_held_for_directions > 0) {
      // Every candidate's direction cell is at its share for this small a drop: a larger drop
      // (the --step budget) raises every cell's share; failing that, no cap (the direction
      // check of the next audit still judges the result).
      drop.max_lines = std::max(1, std::min(round_budget, allowance));
      mitigated = privacy::DropWithKeyframeCoverage(lines, priority, hidden_points, drop,
                                                    &dropped_report);
      if (dropped_report.num_dropped == 0) {
        drop.direction_reference = nullptr;
        mitigated = privacy::DropWithKeyframeCoverage(lines, priority, hidden_points, drop,
                                                      &dropped_report);
      }
    }
    lines = std::move(mitigated);
    mapping::ReapplyInformationRule(convert, &lines);
    dropped_protected += dropped_report.num_dropped_protected;
    rounds.back()["lines_dropped"] = dropped_report.num_dropped;
    rounds.back()["lines_protected"] = dropped_report.num_protected;
    rounds.back()["lines_dropped_protected"] = dropped_report.num_dropped_protected;
    rounds.back()["lines_held_for_directions"] = dropped_report.num_held_for_directions;
    if (dropped_report.num_dropped == 0) {
      verdict = "no line left to drop (every remaining line has risk 0 and was not recovered)";
      break;
    }
  }
  result.coverage_after = privacy::MeasureKeyframeCoverage(lines, hidden_points, coverage);
  result.keyframes_with_12_lines_after = KeyframesWithLines(lines, 12);
  result.lines = std::move(lines);
  return result;
}

}  // namespace lcv::apps
