#include "privacy/reference_match.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "privacy/line_grid.h"
#include "privacy/statistics.h"

namespace lcv::privacy {
namespace {

Eigen::AlignedBox3d TrimmedBox(const std::vector<Eigen::Vector3d>& points, double q) {
  Eigen::AlignedBox3d box;
  if (points.empty()) return box;
  Eigen::Vector3d lo, hi;
  for (int a = 0; a < 3; ++a) {
    std::vector<double> v;
    v.reserve(points.size());
    for (const auto& p : points) v.push_back(p[a]);
    lo[a] = Quantile(v, q);
    hi[a] = Quantile(std::move(v), 1.0 - q);
  }
  return Eigen::AlignedBox3d(lo, hi);
}

}  // namespace

std::string Tolerance::Label() const {
  char buf[64];
  if (relative) {
    std::snprintf(buf, sizeof(buf), "%g%%", value * 100.0);
  } else {
    std::snprintf(buf, sizeof(buf), "%gm", value);
  }
  return buf;
}

ReferenceMatch MatchReference(const slam::Map& line_map, const slam::Map& reference,
                              double on_line_tolerance) {
  ReferenceMatch out;
  const std::size_t n = line_map.lines.size();
  out.hidden_points.assign(n, Eigen::Vector3d::Zero());
  out.matched.assign(n, 0);
  out.num_reference_points = static_cast<int>(reference.points.size());
  if (reference.points.empty() || n == 0) return out;

  Eigen::AlignedBox3d ref_box;
  for (const auto& [id, p] : reference.points) ref_box.extend(p.position);
  const double extent = std::max(ref_box.sizes().maxCoeff(), 1e-9);
  const double tol = on_line_tolerance > 0 ? on_line_tolerance : 1e-6 * extent;

  std::vector<slam::Line3d> lines;
  lines.reserve(n);
  std::vector<slam::Id> line_ids;
  for (const auto& [id, l] : line_map.lines) {
    lines.push_back(l.line);
    line_ids.push_back(id);
  }
  std::vector<unsigned char> point_used;
  std::vector<const slam::PointLandmark*> unmatched;
  for (std::size_t i = 0; i < n; ++i) {
    auto it = reference.points.find(line_ids[i]);
    if (it != reference.points.end() && lines[i].Distance(it->second.position) <= tol) {
      out.hidden_points[i] = it->second.position;
      out.matched[i] = 1;
      ++out.matched_by_id;
    }
  }
  for (const auto& [id, p] : reference.points) {
    auto it = line_map.lines.find(id);
    if (it != line_map.lines.end() && it->second.line.Distance(p.position) <= tol) continue;
    unmatched.push_back(&p);
  }
  if (!unmatched.empty()) {
    Eigen::AlignedBox3d box = ref_box;
    box.extend(ref_box.min() - Eigen::Vector3d::Constant(tol + 1e-9 * extent));
    box.extend(ref_box.max() + Eigen::Vector3d::Constant(tol + 1e-9 * extent));
    const LineGrid grid(lines, box, ChooseVoxelSize(box, n, 8.0));
    for (const slam::PointLandmark* p : unmatched) {
      const Eigen::Vector3i v = grid.VoxelOf(p->position);
      double best = tol;
      std::int64_t best_line = -1;
      // The line passes within tol of the point: it crosses the point's voxel or a neighbour.
      for (int dz = -1; dz <= 1; ++dz) {
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            const Eigen::Vector3i q = v + Eigen::Vector3i(dx, dy, dz);
            if ((q.array() < 0).any() || (q.array() >= grid.dims().array()).any()) continue;
            const std::size_t vi = grid.Index(q.x(), q.y(), q.z());
            for (const std::uint32_t* it = grid.LinesBegin(vi); it != grid.LinesEnd(vi); ++it) {
              if (out.matched[*it]) continue;
              const double d = lines[*it].Distance(p->position);
              if (d <= best) {
                best = d;
                best_line = *it;
              }
            }
          }
        }
      }
      if (best_line >= 0) {
        out.hidden_points[best_line] = p->position;
        out.matched[best_line] = 1;
        ++out.matched_by_geometry;
      }
    }
  }
  std::vector<Eigen::Vector3d> matched_points;
  for (std::size_t i = 0; i < n; ++i) {
    if (out.matched[i]) matched_points.push_back(out.hidden_points[i]);
  }
  const Eigen::AlignedBox3d trimmed = TrimmedBox(matched_points, 0.01);
  out.scene_scale = trimmed.isEmpty() ? 0.0 : trimmed.diagonal().norm();
  return out;
}

RecoveryStats EvaluateRecovery(const LineAttackResult& attack, const ReferenceMatch& match,
                               const std::vector<Tolerance>& tolerances) {
  RecoveryStats stats;
  stats.tolerances = tolerances;
  for (const Tolerance& t : tolerances) {
    stats.tolerances_m.push_back(t.relative ? t.value * match.scene_scale : t.value);
  }
  std::vector<double> errors;
  const std::size_t n = std::min(attack.size(), match.matched.size());
  for (std::size_t i = 0; i < n; ++i) {
    if (!match.matched[i]) continue;
    ++stats.num_hidden_points;
    if (!attack.has_estimate[i]) {
      errors.push_back(std::numeric_limits<double>::infinity());
      continue;
    }
    ++stats.num_estimated;
    errors.push_back((attack.estimates[i] - match.hidden_points[i]).norm());
  }
  if (match.num_matched() > 0) {
    // Unpublished reference points: nothing to attack, never recovered.
    for (int k = 0; k < match.num_unpublished(); ++k) {
      ++stats.num_hidden_points;
      errors.push_back(std::numeric_limits<double>::infinity());
    }
  }
  stats.fractions.assign(tolerances.size(), 0.0);
  stats.precision.assign(tolerances.size(), 0.0);
  std::vector<double> estimate_errors;
  for (const double e : errors) {
    if (std::isfinite(e)) estimate_errors.push_back(e);
  }
  stats.median_estimate_error_m = estimate_errors.empty()
                                      ? std::numeric_limits<double>::infinity()
                                      : Median(estimate_errors);
  for (std::size_t k = 0; k < tolerances.size() && !estimate_errors.empty(); ++k) {
    std::size_t count = 0;
    for (const double e : estimate_errors) count += e <= stats.tolerances_m[k];
    stats.precision[k] = static_cast<double>(count) / estimate_errors.size();
  }
  if (errors.empty()) {
    stats.median_error_m = std::numeric_limits<double>::infinity();
    return stats;
  }
  for (std::size_t k = 0; k < tolerances.size(); ++k) {
    std::size_t count = 0;
    for (double e : errors) count += e <= stats.tolerances_m[k];
    stats.fractions[k] = static_cast<double>(count) / errors.size();
  }
  stats.median_error_m = Median(errors);
  return stats;
}

}  // namespace lcv::privacy
