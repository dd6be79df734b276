#include "slam/feature/orb_extractor.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "slam/util/error.h"

namespace lcv::slam {
namespace {

// ORB's patch: descriptors and orientation read a 31x31 neighbourhood.
constexpr int kPatchSize = 31;
constexpr int kHalfPatchSize = 15;
// Corners closer than this to a level's border are not detected (ORB-SLAM: EDGE_THRESHOLD 19
// minus FAST's radius 3), so that the orientation patch stays inside the level image.
constexpr int kBorder = 16;
constexpr int kFastRadius = 3;

}  // namespace

std::optional<std::string> OrbExtractorOptions::Problem() const {
  if (num_features < 1) return "num_features must be >= 1";
  if (!(scale_factor > 1.0f && scale_factor < 4.0f)) return "scale_factor must be in (1, 4)";
  if (num_levels < 1 || num_levels > 32) return "num_levels must be in [1, 32]";
  if (ini_fast_threshold < 1 || ini_fast_threshold > 255)
    return "ini_fast_threshold must be in [1, 255]";
  if (min_fast_threshold < 1 || min_fast_threshold > ini_fast_threshold)
    return "min_fast_threshold must be in [1, ini_fast_threshold]";
  if (cell_size_px < 8) return "cell_size_px must be >= 8";
  if (!(pole_mask_fraction >= 0.f && pole_mask_fraction < 0.5f))
    return "pole_mask_fraction must be in [0, 0.5)";
  for (const auto& r : mask_rectangles) {
    if (!(r[0] >= 0.f && r[0] < r[1] && r[1] <= 1.f && r[2] >= 0.f && r[2] < r[3] && r[3] <= 1.f))
      return "mask_rectangles entries must be [x_min, x_max, y_min, y_max] with 0 <= min < max <= 1";
  }
  return std::nullopt;
}

void OrbExtractorOptions::Check() const {
  const auto problem = Problem();
  LCV_CHECK(!problem) << *problem;
}

OrbExtractor::OrbExtractor(const OrbExtractorOptions& options)
    : options_(options), pyramid_(options.scale_factor, options.num_levels) {
  options_.Check();
  scales_ = pyramid_.Scales();

  // Level l gets a share proportional to (1 / scale_factor)^l (ORB-SLAM), the last level the
  // remainder, so that the budgets sum to num_features.
  const int levels = options_.num_levels;
  const double factor = 1.0 / options_.scale_factor;
  double per_level = options_.num_features * (1.0 - factor) /
                     (1.0 - std::pow(factor, static_cast<double>(levels)));
  features_per_level_.assign(levels, 0);
  int assigned = 0;
  for (int l = 0; l < levels - 1; ++l) {
    features_per_level_[l] = static_cast<int>(std::lround(per_level));
    assigned += features_per_level_[l];
    per_level *= factor;
  }
  features_per_level_[levels - 1] = std::max(0, options_.num_features - assigned);

  // Circular patch of radius 15: umax_[v] is the half-width of row v (symmetric in u and v).
  umax_.resize(kHalfPatchSize + 1);
  for (int v = 0; v <= kHalfPatchSize; ++v) {
    umax_[v] = static_cast<int>(std::floor(
        std::sqrt(static_cast<double>(kHalfPatchSize * kHalfPatchSize - v * v)) + 0.5));
  }

  // cv::ORB computes rotated BRIEF with its learned pattern on a Gaussian-blurred copy of the
  // image it is given; we give it one level at a time with our keypoints (octave 0, level
  // coordinates). Its edge threshold only drops keypoints closer than that to the border, which
  // ours never are.
  descriptor_ = cv::ORB::create(options_.num_features, 1.2f, 1, kBorder, 0, 2,
                                cv::ORB::HARRIS_SCORE, kPatchSize, options_.ini_fast_threshold);
  levels_.resize(levels);
}

void OrbExtractor::BuildPyramid(const cv::Mat& gray) {
  levels_[0] = gray;
  for (int l = 1; l < options_.num_levels; ++l) {
    const cv::Size size(static_cast<int>(std::lround(gray.cols / scales_[l])),
                        static_cast<int>(std::lround(gray.rows / scales_[l])));
    if (size.width < 1 || size.height < 1) {
      levels_[l].release();
      continue;
    }
    // Resize from the previous level (cheap, and the area filter of INTER_LINEAR over a factor
    // 1.2 is what ORB-SLAM uses).
    cv::resize(levels_[l - 1], levels_[l], size, 0, 0, cv::INTER_LINEAR);
  }
}

bool OrbExtractor::Masked(float x0, float y0, const cv::Mat& mask) const {
  const cv::Mat& image = levels_[0];
  const float fx = x0 / image.cols, fy = y0 / image.rows;
  if (options_.pole_mask_fraction > 0.f &&
      (fy < options_.pole_mask_fraction || fy > 1.f - options_.pole_mask_fraction)) {
    return true;
  }
  for (const auto& r : options_.mask_rectangles) {
    if (fx >= r[0] && fx <= r[1] && fy >= r[2] && fy <= r[3]) return true;
  }
  if (!mask.empty()) {
    const int xi = std::clamp(static_cast<int>(x0 + 0.5f), 0, mask.cols - 1);
    const int yi = std::clamp(static_cast<int>(y0 + 0.5f), 0, mask.rows - 1);
    if (mask.at<unsigned char>(yi, xi) == 0) return true;
  }
  return false;
}

void OrbExtractor::DetectLevel(int level, const cv::Mat& mask) {
  corners_.clear();
  const cv::Mat& image = levels_[level];
  const int min_x = kBorder - kFastRadius, min_y = kBorder - kFastRadius;
  const int max_x = image.cols - kBorder + kFastRadius, max_y = image.rows - kBorder + kFastRadius;
  if (max_x - min_x < 2 * kFastRadius + 2 || max_y - min_y < 2 * kFastRadius + 2) return;

  // ORB-SLAM's scheme: FAST at the initial threshold, and in the grid cells where it found
  // nothing, FAST again at the minimum threshold, so that weakly textured regions still
  // contribute corners. One pass over the level for the first step; the retries only touch
  // the empty cells (with FAST's 3 px margin around them).
  const cv::Mat region = image(cv::Range(min_y, max_y), cv::Range(min_x, max_x));
  fast_keypoints_.clear();
  cv::FAST(region, fast_keypoints_, options_.ini_fast_threshold, true);

  const int cell = options_.cell_size_px;
  const int cells_x = std::max(1, (max_x - min_x) / cell);
  const int cells_y = std::max(1, (max_y - min_y) / cell);
  const float cell_w = static_cast<float>(max_x - min_x) / cells_x;
  const float cell_h = static_cast<float>(max_y - min_y) / cells_y;
  const float ratio_x = static_cast<float>(levels_[0].cols) / image.cols;
  const float ratio_y = static_cast<float>(levels_[0].rows) / image.rows;
  const int num_cells = cells_x * cells_y;

  cell_offsets_.assign(num_cells, 0);  // used as "cell has a corner" flags here
  auto keep = [&](float x, float y, float response) {
    // FAST never returns points within its radius of the region border; keep the
    // orientation patch inside the image.
    if (x < kBorder || y < kBorder || x >= image.cols - kBorder || y >= image.rows - kBorder)
      return;
    if (Masked((x + 0.5f) * ratio_x - 0.5f, (y + 0.5f) * ratio_y - 0.5f, mask)) return;
    corners_.push_back({x, y, response});
  };
  for (const cv::KeyPoint& kp : fast_keypoints_) {
    const int cx = std::min(cells_x - 1, static_cast<int>(kp.pt.x / cell_w));
    const int cy = std::min(cells_y - 1, static_cast<int>(kp.pt.y / cell_h));
    cell_offsets_[cy * cells_x + cx] = 1;
    keep(kp.pt.x + min_x, kp.pt.y + min_y, kp.response);
  }
  if (options_.min_fast_threshold >= options_.ini_fast_threshold) return;
  for (int cy = 0; cy < cells_y; ++cy) {
    for (int cx = 0; cx < cells_x; ++cx) {
      if (cell_offsets_[cy * cells_x + cx]) continue;
      // The cell in region coordinates, grown by FAST's radius where the region allows.
      const int x0 = static_cast<int>(cx * cell_w), x1 = static_cast<int>((cx + 1) * cell_w);
      const int y0 = static_cast<int>(cy * cell_h), y1 = static_cast<int>((cy + 1) * cell_h);
      const int gx0 = std::max(0, x0 - kFastRadius), gx1 = std::min(region.cols, x1 + kFastRadius);
      const int gy0 = std::max(0, y0 - kFastRadius), gy1 = std::min(region.rows, y1 + kFastRadius);
      cell_keypoints_.clear();
      cv::FAST(region(cv::Range(gy0, gy1), cv::Range(gx0, gx1)), cell_keypoints_,
               options_.min_fast_threshold, true);
      for (const cv::KeyPoint& kp : cell_keypoints_) {
        const float rx = kp.pt.x + gx0, ry = kp.pt.y + gy0;
        // Only the cell's own corners (the margins belong to the neighbours).
        if (rx < x0 || rx >= x1 || ry < y0 || ry >= y1) continue;
        keep(rx + min_x, ry + min_y, kp.response);
      }
    }
  }
}

void OrbExtractor::DistributeQuadtree(int level, int budget) {
  selected_.clear();
  const int n = static_cast<int>(corners_.size());
  if (n == 0 || budget <= 0) return;
  node_indices_.resize(n);

  const cv::Mat& image = levels_[level];
  const float x0 = kBorder, x1 = static_cast<float>(image.cols - kBorder);
  const float y0 = kBorder, y1 = static_cast<float>(image.rows - kBorder);
  // Initial nodes: about square, side by side along the wider axis (ORB-SLAM).
  const int initial = std::max(1, static_cast<int>(std::lround((x1 - x0) / (y1 - y0))));
  const float width = (x1 - x0) / initial;
  // Bucket the corners into the initial nodes (counting sort: O(n), deterministic).
  nodes_.clear();
  cell_offsets_.assign(initial + 1, 0);
  auto node_of = [&](const Corner& c) {
    return std::clamp(static_cast<int>((c.x - x0) / width), 0, initial - 1);
  };
  for (const Corner& c : corners_) ++cell_offsets_[node_of(c) + 1];
  for (int k = 0; k < initial; ++k) cell_offsets_[k + 1] += cell_offsets_[k];
  cell_order_.assign(cell_offsets_.begin(), cell_offsets_.end() - 1);
  for (int i = 0; i < n; ++i) node_indices_[cell_order_[node_of(corners_[i])]++] = i;
  for (int k = 0; k < initial; ++k) {
    if (cell_offsets_[k + 1] > cell_offsets_[k]) {
      nodes_.push_back({x0 + k * width, k + 1 == initial ? x1 : x0 + (k + 1) * width, y0, y1,
                        cell_offsets_[k], cell_offsets_[k + 1]});
    }
  }

  // Splits a node into up to four non-empty children appended to *out.
  auto split = [&](const QuadNode& node, std::vector<QuadNode>* out) {
    const float mx = 0.5f * (node.x0 + node.x1), my = 0.5f * (node.y0 + node.y1);
    int* first = node_indices_.data() + node.begin;
    int* last = node_indices_.data() + node.end;
    int* mid_x = std::partition(first, last, [&](int i) { return corners_[i].x < mx; });
    int* mid_left = std::partition(first, mid_x, [&](int i) { return corners_[i].y < my; });
    int* mid_right = std::partition(mid_x, last, [&](int i) { return corners_[i].y < my; });
    const int base = node.begin;
    auto offset = [&](int* p) { return base + static_cast<int>(p - first); };
    const QuadNode children[4] = {
        {node.x0, mx, node.y0, my, base, offset(mid_left)},
        {mx, node.x1, node.y0, my, offset(mid_x), offset(mid_right)},
        {node.x0, mx, my, node.y1, offset(mid_left), offset(mid_x)},
        {mx, node.x1, my, node.y1, offset(mid_right), node.end}};
    for (const QuadNode& child : children) {
      if (child.end > child.begin) out->push_back(child);
    }
  };

  // A node is split while it holds more than one corner and is wider than a pixel (corners
  // are distinct pixels, the size test only guards the loop).
  auto splittable_node = [](const QuadNode& node) {
    return node.end - node.begin > 1 && node.x1 - node.x0 > 1.f;
  };
  while (static_cast<int>(nodes_.size()) < budget) {
    int splittable = 0;
    for (const QuadNode& node : nodes_) splittable += splittable_node(node);
    if (splittable == 0) break;
    next_nodes_.clear();
    if (static_cast<int>(nodes_.size()) + 3 * splittable <= budget) {
      for (const QuadNode& node : nodes_) {
        if (splittable_node(node)) {
          split(node, &next_nodes_);
        } else {
          next_nodes_.push_back(node);
        }
      }
    } else {
      // Close to the budget: split the most populated nodes first, one at a time.
      std::stable_sort(nodes_.begin(), nodes_.end(), [](const QuadNode& a, const QuadNode& b) {
        return a.end - a.begin > b.end - b.begin;
      });
      int count = static_cast<int>(nodes_.size());
      size_t k = 0;
      for (; k < nodes_.size() && count < budget; ++k) {
        const QuadNode& node = nodes_[k];
        if (!splittable_node(node)) {
          next_nodes_.push_back(node);
          continue;
        }
        const size_t before = next_nodes_.size();
        split(node, &next_nodes_);
        count += static_cast<int>(next_nodes_.size() - before) - 1;
      }
      for (; k < nodes_.size(); ++k) next_nodes_.push_back(nodes_[k]);
    }
    std::swap(nodes_, next_nodes_);
  }

  // The strongest corner of each node (lowest index on ties: deterministic).
  for (const QuadNode& node : nodes_) {
    int best = node_indices_[node.begin];
    for (int k = node.begin + 1; k < node.end; ++k) {
      const int i = node_indices_[k];
      if (corners_[i].response > corners_[best].response ||
          (corners_[i].response == corners_[best].response && i < best)) {
        best = i;
      }
    }
    selected_.push_back(best);
  }
  if (static_cast<int>(selected_.size()) > budget) {
    // The last split may overshoot by up to 3: drop the weakest.
    std::stable_sort(selected_.begin(), selected_.end(), [&](int a, int b) {
      return corners_[a].response > corners_[b].response;
    });
    selected_.resize(budget);
  }
  // Row-major order of the kept corners (deterministic, cache-friendly for the descriptor).
  std::sort(selected_.begin(), selected_.end(), [&](int a, int b) {
    return corners_[a].y < corners_[b].y || (corners_[a].y == corners_[b].y && corners_[a].x < corners_[b].x);
  });
}

float OrbExtractor::IntensityCentroidAngle(const cv::Mat& image, float x, float y) const {
  const int cx = static_cast<int>(std::lround(x)), cy = static_cast<int>(std::lround(y));
  const unsigned char* center = image.ptr<unsigned char>(cy) + cx;
  const int step = static_cast<int>(image.step1());
  int m_01 = 0, m_10 = 0;
  for (int u = -kHalfPatchSize; u <= kHalfPatchSize; ++u) m_10 += u * center[u];
  for (int v = 1; v <= kHalfPatchSize; ++v) {
    int v_sum = 0;
    const int d = umax_[v];
    for (int u = -d; u <= d; ++u) {
      const int below = center[u + v * step], above = center[u - v * step];
      v_sum += below - above;
      m_10 += u * (below + above);
    }
    m_01 += v * v_sum;
  }
  float angle = cv::fastAtan2(static_cast<float>(m_01), static_cast<float>(m_10));
  if (angle >= 360.f) angle -= 360.f;
  return angle;
}

void OrbExtractor::Extract(const cv::Mat& image, const cv::Mat& mask,
                           std::vector<Keypoint>* keypoints,
                           std::vector<OrbDescriptor>* descriptors) {
  LCV_CHECK(image.type() == CV_8UC1 || image.type() == CV_8UC3)
      << "image type " << image.type() << ", expected CV_8UC1 or CV_8UC3";
  LCV_CHECK(mask.empty() || (mask.type() == CV_8UC1 && mask.size() == image.size()))
      << "mask must be empty or CV_8UC1 of the image's size";
  keypoints->clear();
  descriptors->clear();
  if (image.type() == CV_8UC3) {
    cv::cvtColor(image, gray_, cv::COLOR_BGR2GRAY);
  } else {
    gray_ = image;
  }
  BuildPyramid(gray_);

  for (int level = 0; level < options_.num_levels; ++level) {
    const cv::Mat& level_image = levels_[level];
    if (level_image.empty() || level_image.cols <= 2 * kBorder + 1 ||
        level_image.rows <= 2 * kBorder + 1) {
      continue;
    }
    DetectLevel(level, mask);
    DistributeQuadtree(level, features_per_level_[level]);
    if (selected_.empty()) continue;

    level_keypoints_.clear();
    for (int k = 0; k < static_cast<int>(selected_.size()); ++k) {
      const Corner& corner = corners_[selected_[k]];
      cv::KeyPoint kp(corner.x, corner.y, static_cast<float>(kPatchSize),
                      IntensityCentroidAngle(level_image, corner.x, corner.y), corner.response,
                      0, k);
      level_keypoints_.push_back(kp);
    }
    descriptor_->compute(level_image, level_keypoints_, level_descriptors_);
    // cv::ORB drops keypoints it considers too close to the border (none of ours, by
    // construction) and keeps the order; class_id maps back regardless.
    // Level pixel -> level-0 pixel. cv::resize maps pixel centres, x_src = (x_dst + 0.5) *
    // ratio - 0.5, and the level sizes are rounded, so the exact map uses the size ratios
    // (x * scale, as ORB-SLAM does, is off by (scale - 1) / 2 px: 1.3 px at level 7).
    const float ratio_x = static_cast<float>(levels_[0].cols) / level_image.cols;
    const float ratio_y = static_cast<float>(levels_[0].rows) / level_image.rows;
    for (int r = 0; r < static_cast<int>(level_keypoints_.size()); ++r) {
      const cv::KeyPoint& kp = level_keypoints_[r];
      Keypoint out;
      out.x = (kp.pt.x + 0.5f) * ratio_x - 0.5f;
      out.y = (kp.pt.y + 0.5f) * ratio_y - 0.5f;
      out.angle_deg = kp.angle;
      out.octave = level;
      keypoints->push_back(out);
      OrbDescriptor descriptor;
      std::memcpy(descriptor.data(), level_descriptors_.ptr<unsigned char>(r), 32);
      descriptors->push_back(descriptor);
    }
  }
}

}  // namespace lcv::slam
