#include "privacy/format_check.h"

#include <algorithm>
#include <cmath>

#include "privacy/statistics.h"

namespace lcv::privacy {

FormatCheckResult CheckFormat(const slam::Map& map, const ReferenceMatch* match,
                              const FormatCheckOptions& options) {
  FormatCheckResult out;
  out.num_keyframes = static_cast<int>(map.keyframes.size());
  for (const auto& [id, kf] : map.keyframes) out.num_keypoints += static_cast<int>(kf.keypoints.size());
  out.num_points = static_cast<int>(map.points.size());
  for (const auto& [id, l] : map.lines) {
    out.num_restored_points += l.restored_point.has_value();
    out.num_line_observations += static_cast<int>(l.observations.size());
    const double along = std::abs(l.line.anchor.dot(l.line.direction));
    if (along > options.anchor_tolerance * (1.0 + l.line.anchor.norm())) {
      ++out.num_anchor_rule_violations;
    }
  }
  auto problem = [&](int count, const std::string& what) {
    if (count > 0) out.problems.push_back(std::to_string(count) + " " + what);
  };
  problem(out.num_keyframes, "client keyframes (with " + std::to_string(out.num_keypoints) +
                                 " keypoint coordinates)");
  problem(out.num_points, "point landmarks (point positions)");
  problem(out.num_restored_points, "restored points X' on lines");
  problem(out.num_line_observations, "client observations on lines");
  problem(out.num_anchor_rule_violations,
          "anchors not at the line's closest point to the origin (may encode the hidden point)");

  if (match && match->num_matched() > 0) {
    out.has_reference_test = true;
    std::vector<double> cosines;
    const double scale = std::max(match->scene_scale, 1e-12);
    std::size_t i = 0;
    for (const auto& [id, l] : map.lines) {
      if (match->matched[i]) {
        const Eigen::Vector3d& x = match->hidden_points[i];
        if (x.norm() > 1e-9 * scale) cosines.push_back(l.line.direction.dot(x) / x.norm());
        const double tol = options.anchor_at_point_fraction * scale;
        if ((l.line.anchor - x).norm() <= tol) ++out.num_anchors_at_point;
        // Under the rule |d . X| <= tol happens by chance with probability tol / |X|.
        out.expected_anchors_at_point += std::min(1.0, tol / std::max(x.norm(), 1e-300));
      }
      ++i;
    }
    const KsResult ks = KolmogorovSmirnovUniform(cosines, -1.0, 1.0);
    out.anchor_ks_statistic = ks.statistic;
    out.anchor_ks_p_value = ks.p_value;
    if (cosines.size() >= 8 && ks.p_value < options.alpha) {
      out.problems.push_back("hidden points are not spread along their lines as the anchor rule "
                             "promises (KS p = " + std::to_string(ks.p_value) + ")");
    }
    // A few anchors land on their point by chance (|X| cos = 0); far more means a leak.
    const double e = out.expected_anchors_at_point;
    if (out.num_anchors_at_point > e + 5.0 * std::sqrt(e) + 3.0) {
      problem(out.num_anchors_at_point, "anchors coincide with their hidden point (" +
                                            std::to_string(e) + " expected by chance)");
    }
  }
  out.passed = out.problems.empty();
  return out;
}

}  // namespace lcv::privacy
