// `lcv map publish`: the curator's one step from a point map to a publishable line cloud
// (docs/curation.md): convert (coincident points merged), audit against risk limits, drop lines
// (by default those whose hidden point a failing limit's attack recovers, never below a
// per-server-keyframe coverage) until the limits hold or the budget is spent.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "apps/args.h"
#include "apps/command.h"
#include "mapping/io/atomic_file.h"
#include "mapping/io/map_file.h"
#include "mapping/line_cloud.h"
#include "privacy/audit.h"
#include "privacy/coverage_mitigation.h"
#include "privacy/mitigation.h"
#include "slam/util/error.h"

namespace lcv::apps {
namespace {

using nlohmann::json;

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

int RunMapPublish(int argc, char** argv) {
  ArgParser args(
      "lcv map publish POINT_MAP --out LINES [--fail-on RULES] [--report FILE.json]",
      "Publishes a point map as a line cloud that passes the privacy audit under risk limits:\n"
      "1. converts it (lcv map convert --to-lines), coincident points merged first;\n"
      "2. audits the line cloud against the point map's hidden points (lcv audit --reference)\n"
      "   with the limits of --fail-on (default: the audit's default limits);\n"
      "3. while a limit fails, drops lines in --order and audits again, up to --max-drop of the\n"
      "   lines in total. Orders:\n"
      "   recovered  (default) the lines whose hidden point the attack of a failing limit\n"
      "              recovers, then by risk; per round at most the excess over the limit (and\n"
      "              --step); no direction cell loses more than its share (directions stay\n"
      "              uniform); every server keyframe keeps --min-keyframe-lines lines spread\n"
      "              over an --image-grid grid of its image while other candidates remain;\n"
      "   risk       the earlier mitigation: --step of the lines per round, the riskiest by the\n"
      "              attacks' score within direction cells (no coverage guard).\n"
      "LINES is written only when the audit passes; otherwise exit 3 and the report says why.\n"
      "The report lists every round, what was removed, and the estimated localization cost\n"
      "(server keyframes left with at least 12 lines, p6L's minimum; measure the real cost with\n"
      "lcv localize).",
      "lcv map publish slam_map.lcmap --out published.lcmap --report publish.json");
  args.AddPositional("POINT_MAP", "point map (.lcmap or .json)");
  args.AddOption("--out", "LINES", "line cloud to write (required)");
  args.AddOption("--fail-on", "RULES", "risk limits (see lcv audit --help)",
                 privacy::kDefaultFailRules);
  args.AddOption("--report", "FILE", "JSON report of the rounds");
  args.AddOption("--seed", "N", "seed of the line directions", "0");
  args.AddOption("--order", "ORDER", "recovered or risk: which lines go first (above)",
                 "recovered");
  args.AddOption("--min-keyframe-lines", "N",
                 "coverage guard: lines every server keyframe keeps (or all it has); 0: no guard",
                 "24");
  args.AddOption("--image-grid", "N", "cells per image side of the coverage guard", "4");
  args.AddOption("--step", "F", "largest share of the remaining lines dropped per round", "0.1");
  args.AddOption("--max-drop", "F", "largest share of the lines dropped in total", "0.8");
  args.AddOption("--threads", "N", "audit worker threads; 0 = all cores", "0");
  if (!args.Parse(argc, argv)) return kExitOk;
  const std::string in = args.Positional("POINT_MAP");
  const std::string out = args.Get("--out");
  const double step = args.GetDouble("--step");
  const double max_drop = args.GetDouble("--max-drop");
  if (!(step > 0.0 && step < 1.0)) throw UsageError("--step must be in (0, 1)");
  if (!(max_drop >= 0.0 && max_drop < 1.0)) throw UsageError("--max-drop must be in [0, 1)");
  const std::string order = args.Get("--order");
  if (order != "recovered" && order != "risk") {
    throw UsageError("--order must be recovered or risk, got '" + order + "'");
  }
  privacy::KeyframeCoverageOptions coverage;
  coverage.min_lines_per_keyframe = args.GetInt("--min-keyframe-lines");
  coverage.image_grid = args.GetInt("--image-grid");
  if (coverage.min_lines_per_keyframe < 0) throw UsageError("--min-keyframe-lines must be >= 0");
  if (coverage.image_grid < 1) throw UsageError("--image-grid must be >= 1");
  const bool guard = order == "recovered" && coverage.min_lines_per_keyframe > 0;
  privacy::AuditOptions audit_options;
  try {
    audit_options.fail_rules = privacy::ParseFailRules(args.Get("--fail-on"));
  } catch (const InputError& e) {
    throw UsageError(e.what());
  }
  audit_options.num_threads = args.GetInt("--threads");

  std::cerr << "map publish: reading " << in << "\n";
  const slam::Map points = mapping::ReadMap(in);
  if (points.points.empty()) throw InputError(in, "no points to publish");
  mapping::LineCloudOptions convert;
  convert.seed = args.GetSeed();
  mapping::LineCloudReport conversion;
  slam::Map lines = mapping::ConvertToLineCloud(points, convert, &conversion);
  lines.description = (points.description.empty() ? "" : points.description + " | ") +
                      "lcv map publish --fail-on " + args.Get("--fail-on");
  const std::size_t converted_lines = lines.lines.size();
  const slam::Map converted = lines;  // the direction reference of the mitigation
  const int keyframes_before = KeyframesWithLines(lines, 12);
  std::map<slam::Id, Eigen::Vector3d> hidden_points;  // from the first audit
  privacy::KeyframeCoverageStats coverage_before;
  int dropped_protected = 0;

  json rounds = json::array();
  privacy::AuditReport audit;
  std::string verdict;
  for (int round = 0;; ++round) {
    privacy::AuditInputs inputs;
    inputs.map = &lines;
    inputs.reference = &points;
    audit = privacy::RunAudit(inputs, audit_options, nullptr);
    if (round == 0) {
      hidden_points = privacy::HiddenPointsOf(audit);
      coverage_before = privacy::MeasureKeyframeCoverage(lines, hidden_points, coverage);
    }
    const double dropped = 1.0 - static_cast<double>(lines.lines.size()) / converted_lines;
    rounds.push_back(json{{"round", round},
                          {"lines", lines.lines.size()},
                          {"dropped_fraction", dropped},
                          {"passed", audit.passed},
                          {"attacks", AttackSummary(audit)}});
    std::fprintf(stderr, "map publish: round %d: %zu lines (%.0f%% dropped), audit %s\n", round,
                 lines.lines.size(), 100.0 * dropped, audit.passed ? "passed" : "failed");
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
    if (order == "risk" ? next_drop > max_drop + 1e-9 : allowance <= 0) {
      verdict = "the limits still fail after dropping " + std::to_string(dropped) +
                " of the lines (--max-drop " + std::to_string(max_drop) + ")";
      break;
    }
    std::vector<privacy::LineAttackResult> attacks;
    for (const auto& a : audit.attacks) attacks.push_back(a.result);
    const int round_budget =
        static_cast<int>(std::floor(step * static_cast<double>(lines.lines.size()) + 1e-9));
    if (order == "risk") {
      privacy::MitigationOptions mitigate;
      mitigate.mode = privacy::MitigationMode::kDrop;
      mitigate.fraction = step;
      mitigate.seed = convert.seed + 1 + round;
      privacy::MitigationReport mitigated;
      lines = privacy::MitigateRiskiestLines(lines, privacy::CombineRisks(attacks), {}, mitigate,
                                             &mitigated);
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
        privacy::RecoveredFirstPriority(audit, audit_options.fail_rules, &excess);
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
  const privacy::KeyframeCoverageStats coverage_after =
      privacy::MeasureKeyframeCoverage(lines, hidden_points, coverage);
  auto coverage_json = [&](const privacy::KeyframeCoverageStats& c) {
    return json{{"keyframes_with_min_lines", c.keyframes_with_min_lines},
                {"fewest_lines_in_a_keyframe", c.min_lines},
                {"occupied_image_cells", c.occupied_cells}};
  };
  const int keyframes_after = KeyframesWithLines(lines, 12);
  const json report{
      {"point_map", in},
      {"out", audit.passed ? json(out) : json(nullptr)},
      {"passed", audit.passed},
      {"reason", verdict.empty() ? json(nullptr) : json(verdict)},
      {"fail_on", args.Get("--fail-on")},
      {"points", points.points.size()},
      {"coincident_points_merged", conversion.points_merged_away},
      {"converted_lines", converted_lines},
      {"published_lines", lines.lines.size()},
      {"lines_removed", converted_lines - lines.lines.size()},
      {"estimated_localization_cost",
       {{"server_keyframes", lines.server_keyframes.size()},
        {"keyframes_with_12_lines_before", keyframes_before},
        {"keyframes_with_12_lines_after", keyframes_after},
        {"min_keyframe_lines", coverage.min_lines_per_keyframe},
        {"image_grid", coverage.image_grid},
        {"coverage_before", coverage_json(coverage_before)},
        {"coverage_after", coverage_json(coverage_after)},
        {"lines_dropped_breaking_coverage", dropped_protected}}},
      {"order", order},
      {"rounds", rounds}};
  if (audit.passed) {
    LCV_CHECK(slam::IsPublishedLineCloud(lines)) << "publishing left private data";
    mapping::ValidateMap(lines, out);
    mapping::WriteMap(lines, out);
  }
  if (auto path = args.GetOptional("--report")) {
    mapping::WriteFileAtomically(*path, report.dump(2) + "\n");
  }
  std::printf("published %s: %zu points -> %zu lines (%d coincident points merged)\n",
              in.c_str(), points.points.size(), converted_lines, conversion.points_merged_away);
  std::printf("mitigation: %zu lines dropped in %zu rounds; server keyframes with >= 12 lines: "
              "%d -> %d of %zu\n",
              converted_lines - lines.lines.size(), rounds.size() - 1, keyframes_before,
              keyframes_after, lines.server_keyframes.size());
  std::cout << privacy::AuditSummary(audit);
  if (!audit.passed) {
    std::printf("NOT published: %s\n", verdict.c_str());
    return kExitCheckFailed;
  }
  std::printf("wrote %s\n", out.c_str());
  return kExitOk;
}

}  // namespace

LCV_REGISTER_COMMAND("map publish",
                     "point map -> line cloud that passes the audit's risk limits", RunMapPublish);

}  // namespace lcv::apps
