#pragma once
// ORB features with an even spatial distribution (ORB-SLAM / stella_vslam's ORBextractor):
//
// 1. a scale pyramid (scale_factor, num_levels), num_features split over the levels in a
//    geometric series, level l getting a share proportional to scale_factor^-l (ORB-SLAM);
// 2. per level, FAST on a grid of ~cell_size_px cells with ini_fast_threshold, retried in a
//    cell with min_fast_threshold when it found nothing (textureless cells still contribute);
// 3. a quadtree split of the level until it has as many nodes as the level's feature budget,
//    keeping the strongest corner of each node (even distribution, no cell hogging);
// 4. orientation by intensity centroid on a circular patch of radius 15 (Rublee et al. 2011);
// 5. rotated BRIEF (the learned 256-pair pattern of ORB) on the level blurred by a 7x7 Gaussian
//    (sigma 2), i.e. descriptors compatible with OpenCV's ORB and ORB-SLAM vocabularies.
//
// Keypoints are returned at level-0 pixel coordinates of the input image, with octave and angle
// set. Masks: pixels where `mask` is zero, and pixels in the configured rectangles (e.g. the
// poles of an equirectangular image), produce no keypoints.
//
// Thread safety: an OrbExtractor owns its pyramid and scratch buffers: one per thread.

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "slam/feature/keypoint.h"
#include "slam/feature/scale_pyramid.h"

namespace cv {
class Feature2D;
}

namespace lcv::slam {

struct OrbExtractorOptions {
  int num_features = 1000;
  float scale_factor = 1.2f;
  int num_levels = 8;
  int ini_fast_threshold = 20;  // intensity difference, 0..255
  int min_fast_threshold = 7;
  int cell_size_px = 30;        // FAST grid cell, level pixels
  // Rectangles (fractions of the image: x_min, x_max, y_min, y_max in [0, 1]) where no keypoint
  // is detected, as stella_vslam's mask_rectangles.
  std::vector<std::array<float, 4>> mask_rectangles;
  // For equirectangular images: exclude this fraction of the rows at the top and at the bottom
  // (the stretched poles). 0 disables.
  float pole_mask_fraction = 0.f;

  // Empty when usable, else what is wrong ("scale_factor must be > 1").
  std::optional<std::string> Problem() const;
  // LCV_CHECK on Problem() (throws std::logic_error).
  void Check() const;
  ScalePyramid pyramid() const { return ScalePyramid(scale_factor, num_levels); }
};

class OrbExtractor {
 public:
  // Precondition: options.Check() passes (checked).
  explicit OrbExtractor(const OrbExtractorOptions& options);

  // image: CV_8UC1 (gray) or CV_8UC3 (BGR, converted). mask: empty, or CV_8UC1 of the image's
  // size, nonzero = allowed. Clears and fills the caller-owned vectors (their capacity is reused
  // from frame to frame); descriptors[i] belongs to keypoints[i]. Keypoints are ordered by
  // level, then by position in the quadtree (deterministic for a given image).
  void Extract(const cv::Mat& image, const cv::Mat& mask, std::vector<Keypoint>* keypoints,
               std::vector<OrbDescriptor>* descriptors);

  const OrbExtractorOptions& options() const { return options_; }
  const ScalePyramid& pyramid() const { return pyramid_; }
  // Feature budget of each level (sums to options.num_features).
  const std::vector<int>& features_per_level() const { return features_per_level_; }
  // The pyramid of the last Extract (level 0 = the gray input), for debugging and drawing.
  const std::vector<cv::Mat>& levels() const { return levels_; }

 private:
  struct Corner {
    float x, y;  // level pixels
    float response;
  };
  struct QuadNode {
    float x0, x1, y0, y1;  // bounds, level pixels
    int begin, end;        // range in node_indices_
  };
  void BuildPyramid(const cv::Mat& gray);
  // FAST corners of one level, with the per-cell threshold fallback, outside the masks.
  void DetectLevel(int level, const cv::Mat& mask);
  // Keeps at most `budget` of corners_, spread by the quadtree; indices into corners_ in
  // selected_.
  void DistributeQuadtree(int level, int budget);
  bool Masked(float x0, float y0, const cv::Mat& mask) const;
  float IntensityCentroidAngle(const cv::Mat& level_image, float x, float y) const;

  OrbExtractorOptions options_;
  ScalePyramid pyramid_;
  std::vector<int> features_per_level_;
  std::vector<float> scales_;
  std::vector<int> umax_;  // half-widths of the circular orientation patch, per row offset
  // Scratch reused across frames (STYLE.md 8).
  std::vector<cv::Mat> levels_;
  std::vector<cv::KeyPoint> fast_keypoints_;
  std::vector<Corner> corners_;
  std::vector<cv::KeyPoint> cell_keypoints_;
  std::vector<int> cell_offsets_;  // per grid cell / initial node bookkeeping
  std::vector<int> cell_order_;
  std::vector<int> node_indices_;
  std::vector<QuadNode> nodes_, next_nodes_;
  std::vector<int> selected_;
  std::vector<cv::KeyPoint> level_keypoints_;
  cv::Mat level_descriptors_;
  cv::Mat gray_;
  cv::Ptr<cv::Feature2D> descriptor_;  // cv::ORB, used only for rotated BRIEF on given keypoints
};

}  // namespace lcv::slam
