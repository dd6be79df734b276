#include "slam/data/frame.h"

#include <algorithm>
#include <cmath>

#include "slam/util/error.h"

namespace lcv::slam {

ScaleLevels::ScaleLevels(double scale_factor, int num_levels) : scale_factor_(scale_factor) {
  LCV_CHECK(scale_factor > 1.0 && num_levels >= 1)
      << "scale_factor " << scale_factor << ", num_levels " << num_levels;
  log_scale_factor_ = std::log(scale_factor);
  scale_.resize(num_levels);
  inverse_sigma2_.resize(num_levels);
  double s = 1.0;
  for (int i = 0; i < num_levels; ++i) {
    scale_[i] = s;
    inverse_sigma2_[i] = 1.0 / (s * s);
    s *= scale_factor;
  }
}

int ScaleLevels::PredictOctave(double distance, double max_distance) const {
  if (!(distance > 0.0) || !(max_distance > 0.0)) return 0;
  const double ratio = max_distance / distance;
  const int octave = static_cast<int>(std::ceil(std::log(ratio) / log_scale_factor_));
  return Clamp(octave);
}

void KeypointGrid::Build(const std::vector<Keypoint>& keypoints, int cols, int rows,
                         int cell_size_px) {
  LCV_CHECK(cell_size_px > 0 && cols > 0 && rows > 0);
  cell_size_px_ = cell_size_px;
  grid_cols_ = (cols + cell_size_px - 1) / cell_size_px;
  grid_rows_ = (rows + cell_size_px - 1) / cell_size_px;
  const int num_cells = grid_cols_ * grid_rows_;
  const int n = static_cast<int>(keypoints.size());
  std::vector<int>& cells = cells_.overwrite();
  std::vector<int>& cell_begin = cell_begin_.overwrite();
  std::vector<int>& cell_items = cell_items_.overwrite();
  cells.resize(n);
  cell_begin.assign(num_cells + 1, 0);
  for (int i = 0; i < n; ++i) {
    int cx = static_cast<int>(std::floor(keypoints[i].x / cell_size_px));
    int cy = static_cast<int>(std::floor(keypoints[i].y / cell_size_px));
    cx = std::clamp(cx, 0, grid_cols_ - 1);
    cy = std::clamp(cy, 0, grid_rows_ - 1);
    cells[i] = cy * grid_cols_ + cx;
    ++cell_begin[cells[i] + 1];
  }
  for (int c = 0; c < num_cells; ++c) cell_begin[c + 1] += cell_begin[c];
  cell_items.resize(n);
  std::vector<int> fill(cell_begin.begin(), cell_begin.end() - 1);
  for (int i = 0; i < n; ++i) cell_items[fill[cells[i]]++] = i;
}

void KeypointGrid::Query(const std::vector<Keypoint>& keypoints, float center_x, float center_y,
                         float radius_px, int min_octave, int max_octave,
                         std::vector<int>* indices) const {
  indices->clear();
  if (grid_cols_ == 0) return;
  const float inv = 1.f / static_cast<float>(cell_size_px_);
  const int x0 = std::max(0, static_cast<int>(std::floor((center_x - radius_px) * inv)));
  const int x1 = std::min(grid_cols_ - 1, static_cast<int>(std::floor((center_x + radius_px) * inv)));
  const int y0 = std::max(0, static_cast<int>(std::floor((center_y - radius_px) * inv)));
  const int y1 = std::min(grid_rows_ - 1, static_cast<int>(std::floor((center_y + radius_px) * inv)));
  if (x0 > x1 || y0 > y1) return;
  for (int cy = y0; cy <= y1; ++cy) {
    for (int cx = x0; cx <= x1; ++cx) {
      const int c = cy * grid_cols_ + cx;
      for (int k = cell_begin_[c]; k < cell_begin_[c + 1]; ++k) {
        const int i = cell_items_[k];
        const Keypoint& kp = keypoints[i];
        if (kp.octave < min_octave || (max_octave >= 0 && kp.octave > max_octave)) continue;
        if (std::abs(kp.x - center_x) > radius_px || std::abs(kp.y - center_y) > radius_px) {
          continue;
        }
        indices->push_back(i);
      }
    }
  }
}

int Frame::NumTrackedLandmarks() const {
  int count = 0;
  for (size_t i = 0; i < landmark_ids.size(); ++i) {
    if (landmark_ids[i] != kInvalidId && !is_outlier[i]) ++count;
  }
  return count;
}

void Frame::ResetMatches() {
  std::fill(landmark_ids.begin(), landmark_ids.end(), kInvalidId);
  std::fill(is_outlier.begin(), is_outlier.end(), 0);
}

void PrepareFrame(Frame* frame, int cell_size_px) {
  LCV_CHECK(frame->camera != nullptr);
  LCV_CHECK(frame->descriptors.size() == frame->keypoints.size());
  const int n = frame->num_keypoints();
  std::vector<Eigen::Vector2d> px(n);
  for (int i = 0; i < n; ++i) px[i] = Eigen::Vector2d(frame->keypoints[i].x, frame->keypoints[i].y);
  frame->bearings.resize(n);
  std::vector<unsigned char> valid(n);
  if (n > 0) frame->camera->UnprojectBatch(px.data(), n, frame->bearings.data(), valid.data());
  for (int i = 0; i < n; ++i) {
    if (!valid[i]) frame->bearings[i].setZero();
  }
  frame->grid.Build(frame->keypoints, frame->camera->cols(), frame->camera->rows(), cell_size_px);
  frame->landmark_ids.assign(n, kInvalidId);
  frame->is_outlier.assign(n, 0);
}

}  // namespace lcv::slam
