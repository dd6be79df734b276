#pragma once
// Ground truth for the attacks: the hidden point of each line, from a reference point map, and
// how well an attack recovered them.
//
// Matching: a reference point with the same id as a line is its hidden point (conversion keeps
// the id) if it lies on the line (distance <= on_line_tolerance); the remaining reference points
// are matched to the nearest unmatched line passing within on_line_tolerance of them (lines
// indexed in a LineGrid, not all pairs).

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "privacy/attack_result.h"
#include "slam/data/map.h"

namespace lcv::privacy {

struct ReferenceMatch {
  std::vector<Eigen::Vector3d> hidden_points;  // aligned with line_map.lines (id order)
  std::vector<unsigned char> matched;
  int matched_by_id = 0;
  int matched_by_geometry = 0;
  int num_matched() const { return matched_by_id + matched_by_geometry; }
  // Reference points in all. Those on no published line (dropped by mitigation, say) count as
  // hidden points the attacks did not recover, so recovery before and after a mitigation that
  // drops lines is measured over the same scene.
  int num_reference_points = 0;
  int num_unpublished() const { return num_reference_points - num_matched(); }
  // Diagonal of the box spanned by the matched hidden points between the 1% and 99% quantiles
  // per axis: the "scene scale" that relative tolerances refer to. 0 without matches.
  double scene_scale = 0.0;
};

// on_line_tolerance <= 0: 1e-6 of the reference points' extent.
ReferenceMatch MatchReference(const slam::Map& line_map, const slam::Map& reference,
                              double on_line_tolerance = 0.0);

// A recovery tolerance, absolute (map units) or relative to ReferenceMatch::scene_scale.
struct Tolerance {
  double value = 0.1;
  bool relative = false;  // value is a fraction of the scene scale (0.01 = 1%)
  std::string Label() const;  // "0.1m", "1%"
  bool operator==(const Tolerance& o) const { return value == o.value && relative == o.relative; }
};

struct RecoveryStats {
  int num_hidden_points = 0;  // reference points (matched lines + unpublished): the denominator
  int num_estimated = 0;      // of them, lines the attack produced an estimate for
  std::vector<Tolerance> tolerances;
  std::vector<double> tolerances_m;  // in map units
  std::vector<double> fractions;     // recovered within tolerances_m[k], over num_hidden_points
  // Median over matched lines of |estimate - hidden|, lines without an estimate counting as
  // infinitely wrong (infinity when fewer than half have one).
  double median_error_m = 0.0;
  // The attack's own accuracy, over its estimates on matched lines only: the fraction within
  // tolerances_m[k] (1 - precision[k] are estimates farther than that: for a client's restored
  // points, associations with the wrong point of the line) and the median |estimate - hidden|
  // (infinity without estimates).
  std::vector<double> precision;
  double median_estimate_error_m = 0.0;
};

RecoveryStats EvaluateRecovery(const LineAttackResult& attack, const ReferenceMatch& match,
                               const std::vector<Tolerance>& tolerances);

}  // namespace lcv::privacy
