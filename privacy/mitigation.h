#pragma once
// Check 5, mitigation: what a curator can do about the lines the audit scores riskiest, before
// publishing. Two modes, applied to the `fraction` of lines with the highest risk (ties broken by
// id; lines with risk <= min_risk are never touched):
//
// Within direction cells by default (MitigationOptions::direction_bands), so that what is kept
// stays uniform in direction (check 2).
// - kDrop: remove the lines (and their ids from the server keyframes). Always safe: a line that
//   is not published reveals nothing, and the density around its neighbours drops too. Costs
//   relocalization support.
// - kRerandomize: give the line a new uniformly random direction through a pivot point on it.
//   Careful: the curator publishing the line cloud knows the hidden point X only if it still has
//   the point map; from the line cloud alone it does not. The new line passes through X only if
//   the pivot IS X. With a pivot elsewhere on the line (the attack's estimate when wrong, or the
//   anchor) the new line misses X by |pivot - X| * sin(angle): it becomes a decoy that no longer
//   supports localization and adds a wrong line to the neighbourhood of others. So:
//     * pass the true hidden points as pivots when converting from the point map (exact, keeps
//       the geometry; this is what `lcv map convert` can do since it has the points);
//     * from a line cloud only, pivot on the attack's estimate: exact when the attack was right
//       (the risky lines are mostly those) and a decoy otherwise.
//   Re-randomizing does NOT by itself defeat the density attack: the attack finds X from the
//   neighbouring lines, which are unchanged. It defeats attacks that use the line's own
//   direction/visibility (visibility intervals change) and breaks exact duplicate pairs only if
//   one member of the pair is dropped instead. Measure with the audit before and after.
//   The information matrix follows the publishing rule of mapping/line_cloud.h for the new line
//   (kProxyPoint: from the published line and keyframes alone, with the input's distance
//   floor), and so does the anchor (closest point to the origin).

#include <cstdint>
#include <map>
#include <optional>
#include <string>

#include <Eigen/Core>

#include "privacy/attack_result.h"
#include "slam/data/map.h"

namespace lcv::privacy {

enum class MitigationMode { kDrop, kRerandomize };

struct MitigationOptions {
  MitigationMode mode = MitigationMode::kDrop;
  double fraction = 0.1;  // of all lines, in [0, 1]
  // Direction balance: the riskiest lines are chosen within each of 2 B^2 equal-area cells of
  // (axial) line directions, each cell giving up the same fraction of its lines (largest
  // remainders), instead of by one global ranking. The attacks' risk depends on a line's
  // direction relative to the scene (a line along a facade crosses fewer surfaces), so a global
  // ranking leaves kept directions that fail check 2: measured on the synthetic street, dropping
  // the riskiest 30% made the Bingham test and the KS tests against the ground normal and the
  // viewing axis fail (p < 1e-4). 0: one global ranking.
  // 8 bands (128 cells): with risk a pure function of |d . axis| (the tests' worst case), 4
  // bands still left a detectable step in each band.
  int direction_bands = 8;
  double min_risk = 0.0;
  std::uint64_t seed = 0;  // directions of kRerandomize
};

struct MitigationReport {
  int num_lines = 0;
  int num_changed = 0;        // dropped or re-randomized
  int num_pivot_given = 0;    // re-randomized around a given pivot (others: around the anchor)
  double risk_threshold = 0.0;  // smallest risk among the changed lines
};

// risk: per line id (missing ids count as 0). pivots: points on the lines (per id) to re-randomize
// around; ignored by kDrop. Returns the mitigated copy. Lines that are not changed are copied
// bit for bit.
slam::Map MitigateRiskiestLines(const slam::Map& line_cloud, const std::map<slam::Id, double>& risk,
                                const std::map<slam::Id, Eigen::Vector3d>& pivots,
                                const MitigationOptions& options, MitigationReport* report);

// The direction cell (0 .. 2 bands^2 - 1) of a unit direction, d ~ -d; for tests.
int DirectionCell(const Eigen::Vector3d& direction, int bands);
// Per line id, the largest risk over the attacks.
std::map<slam::Id, double> CombineRisks(const std::vector<LineAttackResult>& attacks);

// A per-line risk file as the audit writes it ("line_id,risk" header, one row per line).
// Throws lcv::InputError naming the file and line on a malformed row or a risk outside [0, 1].
std::map<slam::Id, double> ReadRiskFile(const std::string& path);
// Per line id risk from an audit report (its attacks[i].risk_file, relative to the report's
// folder) or from a risk CSV, told apart by content. With a report: the named attack's risk, or
// without a name the largest risk over all attacks. Throws lcv::InputError naming the file.
std::map<slam::Id, double> ReadRisks(const std::string& path,
                                     const std::optional<std::string>& attack = std::nullopt);
std::string FormatRiskFile(const LineAttackResult& attack);

}  // namespace lcv::privacy
