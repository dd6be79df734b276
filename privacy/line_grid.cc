#include "privacy/line_grid.h"

#include <algorithm>

#include "privacy/parallel.h"
#include "slam/util/error.h"

namespace lcv::privacy {

bool ClipLineToBox(const slam::Line3d& line, const Eigen::AlignedBox3d& box, double* s_min,
                   double* s_max) {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    const double p = line.anchor[a];
    const double d = line.direction[a];
    if (std::abs(d) < 1e-300) {
      if (p < box.min()[a] || p > box.max()[a]) return false;
      continue;
    }
    double t0 = (box.min()[a] - p) / d;
    double t1 = (box.max()[a] - p) / d;
    if (t0 > t1) std::swap(t0, t1);
    lo = std::max(lo, t0);
    hi = std::min(hi, t1);
  }
  if (!(hi > lo)) return false;
  *s_min = lo;
  *s_max = hi;
  return true;
}

double ChooseVoxelSize(const Eigen::AlignedBox3d& box, std::size_t num_lines,
                       double target_occupancy, std::size_t max_voxels) {
  LCV_CHECK(!box.isEmpty() && target_occupancy > 0);
  const Eigen::Vector3d e = box.sizes();
  const double volume = std::max(e.prod(), 1e-300);
  // Mean chord of a convex body hit by random lines: 4 V / S (Cauchy); a walk crosses on average
  // 1.5 voxels per voxel edge of length (mean of |dx|+|dy|+|dz| over the sphere).
  const double surface = 2.0 * (e.x() * e.y() + e.y() * e.z() + e.x() * e.z());
  const double mean_chord = 4.0 * volume / std::max(surface, 1e-300);
  const double n = std::max<double>(num_lines, 1.0);
  double v = std::sqrt(target_occupancy * volume / (1.5 * n * mean_chord));
  const double min_v = std::cbrt(volume / static_cast<double>(max_voxels));
  v = std::max(v, min_v);
  // At least one voxel per axis extent / 1024 and not more than the largest extent.
  v = std::max(v, e.maxCoeff() / 1024.0);
  return std::min(v, e.maxCoeff());
}

LineGrid::LineGrid(const std::vector<slam::Line3d>& lines, const Eigen::AlignedBox3d& box,
                   double voxel_size, int num_threads, bool store_entries)
    : box_(box), voxel_size_(voxel_size) {
  LCV_CHECK(!box.isEmpty() && voxel_size > 0);
  LCV_CHECK(lines.size() < (std::size_t{1} << 32));
  for (int a = 0; a < 3; ++a) {
    dims_[a] = std::max(1, static_cast<int>(std::ceil(box.sizes()[a] / voxel_size - 1e-9)));
  }
  const std::size_t num_voxels = static_cast<std::size_t>(dims_.x()) * dims_.y() * dims_.z();
  const int workers = ResolveThreadCount(num_threads);
  // Pass 1: per-worker counts per voxel; pass 2: each worker fills its own slots, so entries of a
  // voxel come out in ascending line order whatever the number of workers.
  std::vector<std::vector<std::uint32_t>> counts(workers);
  ParallelBlocks(lines.size(), workers, [&](std::size_t begin, std::size_t end, int w) {
    auto& c = counts[w];
    c.assign(num_voxels, 0);
    for (std::size_t i = begin; i < end; ++i) {
      double s0, s1;
      if (!ClipLineToBox(lines[i], box_, &s0, &s1)) continue;
      Traverse(lines[i], s0, s1, [&](std::size_t v, double, double) { ++c[v]; });
    }
  });
  offsets_.assign(num_voxels + 1, 0);
  for (std::size_t v = 0; v < num_voxels; ++v) {
    std::uint64_t total = 0;
    for (int w = 0; w < workers; ++w) total += counts[w].empty() ? 0 : counts[w][v];
    offsets_[v + 1] = static_cast<std::uint32_t>(offsets_[v] + total);
    LCV_CHECK(offsets_[v] + total < (std::uint64_t{1} << 32)) << "line grid too large";
  }
  if (!store_entries) return;
  // Turn counts into per-worker cursors.
  for (std::size_t v = 0; v < num_voxels; ++v) {
    std::uint32_t cursor = offsets_[v];
    for (int w = 0; w < workers; ++w) {
      if (counts[w].empty()) continue;
      const std::uint32_t c = counts[w][v];
      counts[w][v] = cursor;
      cursor += c;
    }
  }
  entries_.resize(offsets_.back());
  ParallelBlocks(lines.size(), workers, [&](std::size_t begin, std::size_t end, int w) {
    auto& cursor = counts[w];
    for (std::size_t i = begin; i < end; ++i) {
      double s0, s1;
      if (!ClipLineToBox(lines[i], box_, &s0, &s1)) continue;
      Traverse(lines[i], s0, s1, [&](std::size_t v, double, double) {
        entries_[cursor[v]++] = static_cast<std::uint32_t>(i);
      });
    }
  });
}

Eigen::Vector3i LineGrid::VoxelOf(const Eigen::Vector3d& p) const {
  Eigen::Vector3i out;
  for (int a = 0; a < 3; ++a) {
    const int i = static_cast<int>(std::floor((p[a] - box_.min()[a]) / voxel_size_));
    out[a] = std::min(dims_[a] - 1, std::max(0, i));
  }
  return out;
}

}  // namespace lcv::privacy
