#pragma once
// Check 1, leakage by format: what the published file itself gives away.
// - no client keyframes (their keypoints are 2D point coordinates), no point landmarks, no
//   restored points X' and no client observations on lines;
// - anchors follow the rule of mapping/line_cloud.h, "the point of the line closest to the map
//   origin", so they depend on the line alone: |anchor . d| <= anchor_tolerance (relative to
//   1 + |anchor|). An anchor set anywhere else (e.g. at the hidden point) may encode it;
// - with a reference (hidden points matched to the lines, privacy/reference_match.h): under the
//   rule with a uniform direction independent of X, the hidden point's position along its line
//   relative to the anchor, t = d . (X - anchor) = d . X, satisfies t / |X| = cos(d, X) ~
//   Uniform(-1, 1). A Kolmogorov-Smirnov test of that, and the count of anchors lying within
//   anchor_at_point_fraction of the scene scale from their hidden point, which fails the check
//   when far above its chance level sum(tol / |X|) (mean + 5 sigma + 3).

#include <string>
#include <vector>

#include "privacy/reference_match.h"
#include "slam/data/map.h"

namespace lcv::privacy {

struct FormatCheckOptions {
  double anchor_tolerance = 1e-6;
  double alpha = 1e-3;
  double anchor_at_point_fraction = 1e-6;
};

struct FormatCheckResult {
  bool passed = true;
  std::vector<std::string> problems;  // one sentence each
  int num_keyframes = 0, num_keypoints = 0, num_points = 0, num_restored_points = 0;
  int num_line_observations = 0, num_anchor_rule_violations = 0;
  // With a reference:
  bool has_reference_test = false;
  double anchor_ks_statistic = 0.0, anchor_ks_p_value = 1.0;
  int num_anchors_at_point = 0;
  double expected_anchors_at_point = 0.0;  // by chance under the rule
};

// match may be null (no reference).
FormatCheckResult CheckFormat(const slam::Map& map, const ReferenceMatch* match,
                              const FormatCheckOptions& options = {});

}  // namespace lcv::privacy
