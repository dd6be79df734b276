#pragma once
// `lcv audit`: every privacy check on a line cloud before it is published (docs/audit.md).
//
//  1. format      leakage by format (privacy/format_check.h)
//  2. directions  direction randomness (privacy/direction_check.h)
//  3. concealed   concealed lines vs the client's map (privacy/concealed_check.h); skipped
//                 without a client map and concealed regions
//  4. duplicates  the duplicate-line attack found no pair (privacy/duplicate_attack.h)
//  5. thresholds  the --fail-on rules on the attacks' recovery (density, visibility, duplicate,
//                 information)
// The audit passes when every check passes. Attacks are reported separately with their recovery
// (given a reference map) and per-line risk.
//
// Thread safety: RunAudit is reentrant; it uses options.num_threads worker threads.

#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "privacy/attack_result.h"
#include "privacy/concealed_check.h"
#include "privacy/density_attack.h"
#include "privacy/direction_check.h"
#include "privacy/duplicate_attack.h"
#include "privacy/format_check.h"
#include "privacy/information_attack.h"
#include "privacy/reference_match.h"
#include "privacy/visibility_attack.h"
#include "slam/data/map.h"

namespace lcv::privacy {

// "density@0.1m=0.05": fail if the density attack recovers more than 5% of the hidden points
// within 0.1 map units; "visibility@2%=0.1": within 2% of the scene scale.
struct FailRule {
  std::string attack;  // "density", "visibility", "duplicate" or "information"
  Tolerance tolerance;
  double max_fraction = 0.0;  // in [0, 1]
  std::string text;           // as written
};
// The curator's default risk limits (`lcv audit` and `lcv map publish` without --fail-on): at
// most 25% of the hidden points recovered within 1% of the scene scale by the density or the
// visibility or the information attack, none by the duplicate attack. Relative, so that they mean the same in a
// monocular SLAM map's arbitrary units and in metres. With a --reference the recovered
// fractions are compared; without one, the attacks' mean per-line risk stands in (see the
// thresholds check). `passed` then means "safe to publish under these limits". Measured on the
// demo's street (docs/curation.md): the raw conversion fails them (density 45% within 1%);
// `lcv map publish` meets them by dropping 20% of the lines (the recovered ones first), and p6L
// still localizes 96.2% of the client frames (0.5 m, 2 deg; 93.8% in the full cloud; 88.8%
// after the earlier risk-ordered drop of 34%).
inline constexpr const char* kDefaultFailRules =
    "density@1%=0.25,visibility@1%=0.25,duplicate@1%=0,information@1%=0.25";

// Comma-separated rules (spaces not allowed). Throws lcv::InputError("--fail-on: ...") naming the
// bad rule and what is wrong with it.
std::vector<FailRule> ParseFailRules(const std::string& text);

struct AuditInputs {
  const slam::Map* map = nullptr;        // the line cloud audited (required)
  const slam::Map* client = nullptr;     // a client's map after LC-VSLAM (check 3)
  const ConcealedSpec* concealed = nullptr;
  const slam::Map* reference = nullptr;  // the point map with the hidden points
};

struct AuditOptions {
  std::vector<Tolerance> tolerances = {{0.05, false}, {0.1, false}, {0.25, false},
                                       {0.5, false},  {0.01, true}, {0.02, true},
                                       {0.05, true}};
  std::vector<FailRule> fail_rules;
  FormatCheckOptions format;
  DirectionCheckOptions directions;
  ConcealedCheckOptions concealed;
  DensityAttackOptions density;
  VisibilityAttackOptions visibility;
  DuplicateAttackOptions duplicate;
  InformationAttackOptions information;
  bool run_density = true;
  bool run_visibility = true;
  bool run_information = true;
  int num_threads = 0;  // passed to every attack
};

struct CheckOutcome {
  std::string name;
  bool passed = true;
  bool skipped = false;
  nlohmann::json details;
};

struct AttackOutcome {
  LineAttackResult result;
  std::optional<RecoveryStats> recovery;  // with a reference
  double mean_risk = 0.0;
  int num_estimated = 0;
  double seconds = 0.0;   // wall time
  std::string risk_file;  // set by WriteAuditReport, relative to the report's folder
  // Per-attack verdict: every --fail-on rule of this attack held (empty: no rule names it).
  std::optional<bool> within_limits;
};

struct AuditReport {
  bool passed = true;
  nlohmann::json inputs;  // sizes of the inputs
  std::vector<CheckOutcome> checks;
  std::vector<AttackOutcome> attacks;
  std::optional<ReferenceMatch> reference_match;
};

// progress (may be null) receives one line per stage.
AuditReport RunAudit(const AuditInputs& inputs, const AuditOptions& options,
                     std::ostream* progress = nullptr);

nlohmann::json AuditReportToJson(const AuditReport& report);

// Writes the per-line risk files "<report stem>.<attack>-risk.csv" next to report_path, records
// their names in report->attacks[i].risk_file, then the JSON report, all atomically. Throws
// lcv::InputError naming the path on I/O failure.
void WriteAuditReport(AuditReport* report, const std::string& report_path);

// A few lines (at most 10) for stdout.
std::string AuditSummary(const AuditReport& report);

}  // namespace lcv::privacy
