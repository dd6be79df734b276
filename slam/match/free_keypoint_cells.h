#pragma once
// The keypoints a search may still match ("free": the caller says which), bucketed into square
// cells of cell_px with their coordinates, octaves and descriptors stored inline in cell order
// (CSR), so that a window scan reads adjacent memory and never looks at a held keypoint. The
// frame's own KeypointGrid (32 px cells, every keypoint, indices into the keypoint array) scans
// ~7-10x a small window's area. Built once per search call, O(keypoints), no allocation once the
// vectors have grown. Used by MatchByProjection and MatchLinesByProjection.
//
//   FreeKeypointCells cells;                  // kept in the matcher's scratch
//   cells.Build(frame, 8, [&](int i) { return frame.landmark_ids[i] == kInvalidId; });
//   cells.ForEachInWindow(x, y, radius, [&](int k) { ... cells.keypoint[k] ... });
//
// Slots k of one cell hold its keypoints in increasing index; cells are row-major.

#include <algorithm>
#include <cmath>
#include <vector>

#include "slam/data/frame.h"
#include "slam/feature/keypoint.h"

namespace lcv::slam {

struct FreeKeypointCells {
  // Per slot k (cell order).
  std::vector<float> x, y;
  std::vector<int> octave;
  std::vector<int> keypoint;  // index into the frame's keypoints
  std::vector<OrbDescriptor> descriptor;

  int num_slots() const { return static_cast<int>(keypoint.size()); }

  template <typename IsFree>
  void Build(const Frame& frame, int cell_px, const IsFree& is_free) {
    inv_cell_ = 1.f / static_cast<float>(cell_px);
    cols_ = (frame.camera->cols() + cell_px - 1) / cell_px;
    rows_ = (frame.camera->rows() + cell_px - 1) / cell_px;
    const int n = frame.num_keypoints();
    cell_begin_.assign(cols_ * rows_ + 1, 0);
    keypoint_cell_.resize(n);
    for (int i = 0; i < n; ++i) {
      keypoint_cell_[i] = -1;
      if (!is_free(i)) continue;
      keypoint_cell_[i] = Cell(frame.keypoints[i].x, frame.keypoints[i].y);
      ++cell_begin_[keypoint_cell_[i] + 1];
    }
    for (int c = 0; c < cols_ * rows_; ++c) cell_begin_[c + 1] += cell_begin_[c];
    const int num_free = cell_begin_.back();
    x.resize(num_free);
    y.resize(num_free);
    octave.resize(num_free);
    keypoint.resize(num_free);
    descriptor.resize(num_free);
    cell_fill_.assign(cell_begin_.begin(), cell_begin_.end() - 1);
    for (int i = 0; i < n; ++i) {
      if (keypoint_cell_[i] < 0) continue;
      const int k = cell_fill_[keypoint_cell_[i]]++;
      const Keypoint& kp = frame.keypoints[i];
      x[k] = kp.x;
      y[k] = kp.y;
      octave[k] = kp.octave;
      keypoint[k] = i;
      descriptor[k] = frame.descriptors[i];
    }
  }

  // Calls visit(k) for every slot whose keypoint is within radius of (cx, cy) on both axes (a
  // square window, as KeypointGrid::Query), in cell order.
  template <typename Visit>
  void ForEachInWindow(float cx, float cy, float radius, const Visit& visit) const {
    const float lo_x = (cx - radius) * inv_cell_, hi_x = (cx + radius) * inv_cell_;
    const float lo_y = (cy - radius) * inv_cell_, hi_y = (cy + radius) * inv_cell_;
    if (hi_x < 0.f || hi_y < 0.f) return;
    // Truncation equals floor here: the lower bounds are clamped to 0 anyway (and std::floor is
    // a libm call without SSE4.1).
    const int x0 = std::max(0, static_cast<int>(lo_x));
    const int x1 = std::min(cols_ - 1, static_cast<int>(hi_x));
    const int y0 = std::max(0, static_cast<int>(lo_y));
    const int y1 = std::min(rows_ - 1, static_cast<int>(hi_y));
    if (x0 > x1 || y0 > y1) return;
    for (int row = y0; row <= y1; ++row) {
      const int end = cell_begin_[row * cols_ + x1 + 1];
      for (int k = cell_begin_[row * cols_ + x0]; k < end; ++k) {  // a row's cells are adjacent
        if (std::abs(x[k] - cx) <= radius && std::abs(y[k] - cy) <= radius) visit(k);
      }
    }
  }

 private:
  int Cell(float px, float py) const {
    const int cx = std::clamp(static_cast<int>(std::floor(px * inv_cell_)), 0, cols_ - 1);
    const int cy = std::clamp(static_cast<int>(std::floor(py * inv_cell_)), 0, rows_ - 1);
    return cy * cols_ + cx;
  }

  float inv_cell_ = 0.125f;
  int cols_ = 0, rows_ = 0;
  std::vector<int> cell_begin_;     // slots of cell c: [cell_begin_[c], cell_begin_[c + 1])
  std::vector<int> cell_fill_;      // build only
  std::vector<int> keypoint_cell_;  // build only: cell of each keypoint, -1 when not free
};

}  // namespace lcv::slam
