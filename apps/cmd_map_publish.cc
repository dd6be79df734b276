// `lcv map publish`: the curator's one step from a point map to a publishable line cloud
// (docs/curation.md): convert (coincident points merged), audit against risk limits, drop lines
// (by default those whose hidden point a failing limit's attack recovers, never below a
// per-server-keyframe coverage) until the limits hold or the budget is spent.
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>

#include "apps/args.h"
#include "apps/command.h"
#include "apps/publish_gate.h"
#include "mapping/io/atomic_file.h"
#include "mapping/io/map_file.h"
#include "privacy/audit.h"
#include "privacy/coverage_mitigation.h"
#include "slam/util/error.h"

namespace lcv::apps {
namespace {

using nlohmann::json;

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
  PublishGateOptions gate;
  gate.audit = audit_options;
  gate.seed = args.GetSeed();
  gate.order = order == "risk" ? PublishOrder::kRisk : PublishOrder::kRecovered;
  gate.coverage = coverage;
  gate.step = step;
  gate.max_drop = max_drop;
  PublishGateResult gated = RunPublishGate(points, gate, &std::cerr);
  slam::Map& lines = gated.lines;
  lines.description = (points.description.empty() ? "" : points.description + " | ") +
                      "lcv map publish --fail-on " + args.Get("--fail-on");
  const privacy::AuditReport& audit = gated.audit;
  const std::string& verdict = gated.verdict;
  const std::size_t converted_lines = gated.converted_lines;
  const json& rounds = gated.rounds;
  auto coverage_json = [&](const privacy::KeyframeCoverageStats& c) {
    return json{{"keyframes_with_min_lines", c.keyframes_with_min_lines},
                {"fewest_lines_in_a_keyframe", c.min_lines},
                {"occupied_image_cells", c.occupied_cells}};
  };
  const json report{
      {"point_map", in},
      {"out", audit.passed ? json(out) : json(nullptr)},
      {"passed", audit.passed},
      {"reason", verdict.empty() ? json(nullptr) : json(verdict)},
      {"fail_on", args.Get("--fail-on")},
      {"points", points.points.size()},
      {"coincident_points_merged", gated.coincident_points_merged},
      {"converted_lines", converted_lines},
      {"published_lines", lines.lines.size()},
      {"lines_removed", converted_lines - lines.lines.size()},
      {"estimated_localization_cost",
       {{"server_keyframes", lines.server_keyframes.size()},
        {"keyframes_with_12_lines_before", gated.keyframes_with_12_lines_before},
        {"keyframes_with_12_lines_after", gated.keyframes_with_12_lines_after},
        {"min_keyframe_lines", coverage.min_lines_per_keyframe},
        {"image_grid", coverage.image_grid},
        {"coverage_before", coverage_json(gated.coverage_before)},
        {"coverage_after", coverage_json(gated.coverage_after)},
        {"lines_dropped_breaking_coverage", gated.lines_dropped_breaking_coverage}}},
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
              in.c_str(), points.points.size(), converted_lines, gated.coincident_points_merged);
  std::printf("mitigation: %zu lines dropped in %zu rounds; server keyframes with >= 12 lines: "
              "%d -> %d of %zu\n",
              converted_lines - lines.lines.size(), rounds.size() - 1,
              gated.keyframes_with_12_lines_before, gated.keyframes_with_12_lines_after,
              lines.server_keyframes.size());
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
