#include "privacy/scene_box.h"

#include <algorithm>
#include <cmath>

#include "privacy/line_grid.h"
#include "privacy/parallel.h"
#include "privacy/statistics.h"

namespace lcv::privacy {

Eigen::AlignedBox3d EstimateSceneBox(const std::vector<slam::Line3d>& lines,
                                     const std::vector<Eigen::Vector3d>& camera_centers,
                                     const SceneBoxOptions& options) {
  Eigen::AlignedBox3d out;  // empty
  if (lines.empty()) return out;
  std::vector<double> anchor_norms;
  anchor_norms.reserve(lines.size());
  for (const auto& l : lines) anchor_norms.push_back(l.anchor.norm());
  double radius = 1.5 * Quantile(anchor_norms, 0.999);
  for (const auto& c : camera_centers) radius = std::max(radius, 1.1 * c.norm());
  radius = std::max(radius, 1e-3);
  const Eigen::AlignedBox3d cube(Eigen::Vector3d::Constant(-radius),
                                 Eigen::Vector3d::Constant(radius));
  const double voxel = 2.0 * radius / std::max(4, options.coarse_voxels_per_axis);
  const LineGrid counts(lines, cube, voxel, options.num_threads, /*store_entries=*/false);

  const std::size_t stride =
      std::max<std::size_t>(1, lines.size() / std::max(1, options.max_samples));
  std::vector<Eigen::Vector3d> peaks;
  for (std::size_t i = 0; i < lines.size(); i += stride) {
    double s0, s1;
    if (!ClipLineToBox(lines[i], cube, &s0, &s1)) continue;
    std::uint32_t best = 0;
    double best_s = 0.0;
    counts.Traverse(lines[i], s0, s1, [&](std::size_t v, double a, double b) {
      if (counts.Count(v) > best) {
        best = counts.Count(v);
        best_s = 0.5 * (a + b);
      }
    });
    if (best > 1) peaks.push_back(lines[i].PointAt(best_s));
  }
  if (peaks.empty()) return cube;
  Eigen::Vector3d lo, hi;
  for (int a = 0; a < 3; ++a) {
    std::vector<double> values;
    values.reserve(peaks.size());
    for (const auto& p : peaks) values.push_back(p[a]);
    lo[a] = Quantile(values, options.trim_quantile);
    hi[a] = Quantile(values, 1.0 - options.trim_quantile);
  }
  const Eigen::Vector3d pad =
      (options.padding_fraction * (hi - lo)).cwiseMax(Eigen::Vector3d::Constant(voxel));
  return Eigen::AlignedBox3d(lo - pad, hi + pad);
}

}  // namespace lcv::privacy
