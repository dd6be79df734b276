#pragma once
// A voxel index of 3D lines clipped to a box: the spatial index every line attack shares, so that
// no attack looks at all pairs of lines.
//
// Lines are infinite; only their part inside the box (the scene) is indexed. Each voxel lists
// the lines that cross it (compressed rows of line indices, ascending), built by walking every
// line through the grid (Amanatides & Woo 1987). Lines that cross voxel v are the candidates for
// "lines passing near a point of v"; callers refine with exact geometry.
//
// Memory: 4 bytes per (line, crossed voxel) plus 4 bytes per voxel. ChooseVoxelSize picks the
// voxel so that a voxel holds about target_occupancy lines on average.
// Thread safety: immutable after construction; all methods may be called concurrently.

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "slam/geometry/line3.h"

namespace lcv::privacy {

// The parameter interval [s_min, s_max] of line inside box; false when the line misses it.
bool ClipLineToBox(const slam::Line3d& line, const Eigen::AlignedBox3d& box, double* s_min,
                   double* s_max);

// Voxel edge (box units) giving about target_occupancy lines per voxel for num_lines lines,
// limited so that the grid has at most max_voxels voxels.
double ChooseVoxelSize(const Eigen::AlignedBox3d& box, std::size_t num_lines,
                       double target_occupancy, std::size_t max_voxels = 1u << 24);

class LineGrid {
 public:
  // Indexes lines (by their position in the vector) in a grid of cubic voxels of edge voxel_size
  // covering box. Precondition: box not empty, voxel_size > 0, lines.size() < 2^32.
  // With store_entries false only the per-voxel counts are kept (LinesBegin/End are empty).
  LineGrid(const std::vector<slam::Line3d>& lines, const Eigen::AlignedBox3d& box,
           double voxel_size, int num_threads = 0, bool store_entries = true);

  const Eigen::AlignedBox3d& box() const { return box_; }
  double voxel_size() const { return voxel_size_; }
  const Eigen::Vector3i& dims() const { return dims_; }
  std::size_t num_voxels() const { return offsets_.size() - 1; }
  std::size_t num_entries() const { return entries_.size(); }

  // Lines crossing voxel v: [LinesBegin(v), LinesEnd(v)).
  const std::uint32_t* LinesBegin(std::size_t v) const { return entries_.data() + offsets_[v]; }
  const std::uint32_t* LinesEnd(std::size_t v) const { return entries_.data() + offsets_[v + 1]; }
  std::uint32_t Count(std::size_t v) const { return offsets_[v + 1] - offsets_[v]; }

  // Voxel of a point inside the box (clamped to the grid).
  Eigen::Vector3i VoxelOf(const Eigen::Vector3d& p) const;
  std::size_t Index(int x, int y, int z) const {
    return (static_cast<std::size_t>(z) * dims_.y() + y) * dims_.x() + x;
  }

  // Calls visit(voxel_index, s_enter, s_exit) for each voxel crossed by line between parameters
  // s0 < s1 (which must lie inside the box, e.g. from ClipLineToBox), in order along the line.
  template <typename Visit>
  void Traverse(const slam::Line3d& line, double s0, double s1, Visit&& visit) const;

 private:
  Eigen::AlignedBox3d box_;
  double voxel_size_ = 1.0;
  Eigen::Vector3i dims_ = Eigen::Vector3i::Ones();
  std::vector<std::uint32_t> offsets_;  // num_voxels + 1
  std::vector<std::uint32_t> entries_;
};

template <typename Visit>
void LineGrid::Traverse(const slam::Line3d& line, double s0, double s1, Visit&& visit) const {
  const Eigen::Vector3d p0 = (line.PointAt(s0) - box_.min()) / voxel_size_;
  const Eigen::Vector3d& d = line.direction;
  int ix[3], step[3];
  double s_next[3], s_delta[3];
  constexpr double kInf = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    ix[a] = std::min(dims_[a] - 1, std::max(0, static_cast<int>(std::floor(p0[a]))));
    if (d[a] > 0) {
      step[a] = 1;
      s_delta[a] = voxel_size_ / d[a];
      s_next[a] = s0 + (ix[a] + 1 - p0[a]) * s_delta[a];
    } else if (d[a] < 0) {
      step[a] = -1;
      s_delta[a] = -voxel_size_ / d[a];
      s_next[a] = s0 + (p0[a] - ix[a]) * s_delta[a];
    } else {
      step[a] = 0;
      s_delta[a] = kInf;
      s_next[a] = kInf;
    }
  }
  double s = s0;
  while (true) {
    const int a = s_next[0] < s_next[1] ? (s_next[0] < s_next[2] ? 0 : 2)
                                        : (s_next[1] < s_next[2] ? 1 : 2);
    const double s_exit = std::min(s_next[a], s1);
    visit(Index(ix[0], ix[1], ix[2]), s, s_exit);
    if (s_next[a] >= s1) break;
    s = s_next[a];
    ix[a] += step[a];
    if (ix[a] < 0 || ix[a] >= dims_[a]) break;
    s_next[a] += s_delta[a];
  }
}

}  // namespace lcv::privacy
