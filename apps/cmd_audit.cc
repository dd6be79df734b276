// `lcv audit`: privacy audit of a line cloud before publishing (privacy/audit.h, docs/audit.md).
#include <iostream>
#include <optional>

#include "apps/args.h"
#include "apps/command.h"
#include "mapping/io/map_file.h"
#include "privacy/audit.h"
#include "privacy/concealed_regions.h"
#include "slam/util/error.h"

namespace lcv::apps {
namespace {

int RunAudit(int argc, char** argv) {
  ArgParser args(
      "lcv audit MAP --report FILE.json [--client CLIENT_MAP] [--scene scene.json | "
      "--concealed REGIONS.json] [--reference POINTS_MAP] [--fail-on RULES]",
      "Audits a line cloud for privacy leaks: leakage by format, direction randomness, concealed\n"
      "lines in a client's map, and the density, visibility, duplicate-line and information\n"
      "attacks (privacy/information_attack.h: the point's distance read from Omega_L); with\n"
      "--client, the client's restored points X' as one more estimate of the hidden points\n"
      "(reported, with --reference their precision, never a limit). Writes a\n"
      "JSON report and one per-line risk CSV per attack next to it (format: docs/audit.md).\n"
      "Fails (exit 3) on any format leak, non-uniform directions, concealed-line violation or\n"
      "duplicate-line pair, and on attack recovery past the --fail-on thresholds.\n"
      "RULES: comma-separated ATTACK@TOLERANCE=FRACTION with ATTACK in {density, visibility,\n"
      "duplicate, information} and TOLERANCE in map units (0.1m) or percent of the scene scale (2%);\n"
      "density@0.1m=0.05 fails if the density attack recovers more than 5% of the points within\n"
      "0.1 m (with --reference; without it the mean per-line risk is compared).\n"
      "Without --fail-on the curator's default limits apply (" + std::string(privacy::kDefaultFailRules) + "),\n"
      "so that 'passed' means safe to publish under them; each attack gets its own verdict\n"
      "(attacks[].passed). --fail-on none audits without limits.\n"
      "Exit codes: 0 passed, 1 bad input, 2 usage error, 3 a check failed.",
      "lcv audit map.lcmap --reference points.lcmap --report audit/report.json "
      "--fail-on density@0.1m=0.05");
  args.AddPositional("MAP", "the line cloud to audit (.lcmap or .json)");
  args.AddOption("--report", "FILE.json", "where to write the JSON report (required)");
  args.AddOption("--client", "CLIENT_MAP", "a client's map after LC-VSLAM, for the concealed check and the client's X'");
  args.AddOption("--scene", "scene.json", "concealed regions from a synthetic scene's objects");
  args.AddOption("--concealed", "REGIONS.json", "concealed regions / line ids (docs/audit.md)");
  args.AddOption("--reference", "POINTS_MAP", "point map holding the hidden points (ground truth)");
  args.AddOption("--fail-on", "RULES",
                 std::string("attack recovery limits, e.g. density@0.1m=0.05; 'none': no limit "
                             "(default: ") + privacy::kDefaultFailRules + ")");
  args.AddOption("--epsilon", "M", "concealed check: distance from a concealed line, map units",
                 "0.05");
  args.AddOption("--region-margin", "M",
                 "concealed check: client points count within M of a region's box; < 0: any "
                 "point within --epsilon of the lines' parts",
                 "0.01");
  args.AddSwitch("--points-by-position",
                 "concealed check: judge client points X by their position alone (default: a "
                 "point its own observations also allow outside the zone is cleared)");
  args.AddOption("--alpha", "P", "false-alarm rate of the statistical tests", "0.001");
  args.AddOption("--far", "M", "visibility attack: max camera-to-point distance; 0 = scene box "
                 "diagonal", "0");
  args.AddOption("--near", "M", "visibility attack: min camera-to-point distance", "0");
  args.AddOption("--threads", "N", "worker threads; 0 = all cores", "0");
  args.AddOption("--seed", "N", "seed of the randomized parts (plane RANSAC)", "0");
  args.AddSwitch("--skip-density", "do not run the density attack");
  args.AddSwitch("--skip-visibility", "do not run the visibility attack");
  args.AddSwitch("--skip-information", "do not run the information attack");
  if (!args.Parse(argc, argv)) return kExitOk;
  args.CheckOutputs({"--report"});  // before any work

  const std::string map_path = args.Positional("MAP");
  const std::string report_path = args.Get("--report");
  if (args.Has("--scene") && args.Has("--concealed")) {
    throw UsageError("--scene and --concealed are alternatives; give one");
  }
  privacy::AuditOptions options;
  {
    const std::string rules = args.GetOptional("--fail-on").value_or(privacy::kDefaultFailRules);
    try {
      if (rules != "none") options.fail_rules = privacy::ParseFailRules(rules);
    } catch (const InputError& e) {
      throw UsageError(e.what());
    }
  }
  options.concealed.epsilon_m = args.GetDouble("--epsilon");
  options.concealed.point_region_margin_m = args.GetDouble("--region-margin");
  options.concealed.clear_points_by_observations = !args.Has("--points-by-position");
  options.directions.alpha = args.GetDouble("--alpha");
  options.format.alpha = options.directions.alpha;
  options.visibility.far_m = args.GetDouble("--far");
  options.visibility.near_m = args.GetDouble("--near");
  options.num_threads = args.GetInt("--threads");
  options.directions.seed = args.GetSeed("--seed");
  options.run_density = !args.Has("--skip-density");
  options.run_visibility = !args.Has("--skip-visibility");
  options.run_information = !args.Has("--skip-information");
  if (!(options.concealed.epsilon_m > 0)) throw UsageError("--epsilon must be > 0");
  if (!(options.directions.alpha > 0 && options.directions.alpha < 1)) {
    throw UsageError("--alpha must be in (0, 1)");
  }
  if (options.num_threads < 0) throw UsageError("--threads must be >= 0");

  std::cerr << "audit: reading " << map_path << "\n";
  const slam::Map map = mapping::ReadMap(map_path);
  std::optional<slam::Map> client, reference;
  std::optional<privacy::ConcealedSpec> concealed;
  if (auto p = args.GetOptional("--client")) client = mapping::ReadMap(*p);
  if (auto p = args.GetOptional("--reference")) reference = mapping::ReadMap(*p);
  if (auto p = args.GetOptional("--scene")) concealed = privacy::ReadSceneConcealedRegions(*p);
  if (auto p = args.GetOptional("--concealed")) concealed = privacy::ReadConcealedRegions(*p);

  privacy::AuditInputs inputs;
  inputs.map = &map;
  inputs.client = client ? &*client : nullptr;
  inputs.reference = reference ? &*reference : nullptr;
  inputs.concealed = concealed ? &*concealed : nullptr;
  privacy::AuditReport report = privacy::RunAudit(inputs, options, &std::cerr);
  privacy::WriteAuditReport(&report, report_path);
  std::cout << privacy::AuditSummary(report) << "report: " << report_path << "\n";
  return report.passed ? kExitOk : kExitCheckFailed;
}

}  // namespace
LCV_REGISTER_COMMAND("audit", "privacy audit of a line cloud (attacks, leaks, concealed objects)",
                     RunAudit);
}  // namespace lcv::apps
