#include "slam/feature/orb_extractor.h"

#include <cmath>
#include <fstream>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace lcv::slam {
namespace {

// A textured test image: random filled rectangles and circles of random gray levels, lightly
// blurred (corners everywhere, no two images alike for different seeds). contrast scales the
// deviation from mid-gray.
cv::Mat MakeTexture(int cols, int rows, std::uint64_t seed, double contrast = 1.0) {
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> x(0, cols - 1), y(0, rows - 1), size(3, 25), gray(0, 255);
  cv::Mat image(rows, cols, CV_8UC1, cv::Scalar(128));
  for (int i = 0; i < cols * rows / 60; ++i) {
    const int value = static_cast<int>(128 + contrast * (gray(rng) - 128));
    if (i % 2) {
      cv::rectangle(image, cv::Rect(x(rng), y(rng), size(rng), size(rng)), cv::Scalar(value),
                    cv::FILLED);
    } else {
      cv::circle(image, cv::Point(x(rng), y(rng)), size(rng) / 2, cv::Scalar(value), cv::FILLED);
    }
  }
  cv::GaussianBlur(image, image, cv::Size(3, 3), 0.8);
  return image;
}

struct Features {
  std::vector<Keypoint> keypoints;
  std::vector<OrbDescriptor> descriptors;
};

Features Extract(OrbExtractor& extractor, const cv::Mat& image, const cv::Mat& mask = cv::Mat()) {
  Features f;
  extractor.Extract(image, mask, &f.keypoints, &f.descriptors);
  return f;
}

TEST(OrbExtractor, CountCloseToRequestedAndLevelsFollowBudget) {
  const cv::Mat image = MakeTexture(640, 360, 1);
  for (int requested : {500, 1000, 2000}) {
    OrbExtractorOptions options;
    options.num_features = requested;
    OrbExtractor extractor(options);
    int budget_sum = 0;
    for (int b : extractor.features_per_level()) budget_sum += b;
    EXPECT_EQ(budget_sum, requested);
    const Features f = Extract(extractor, image);
    ASSERT_EQ(f.keypoints.size(), f.descriptors.size());
    EXPECT_GE(static_cast<int>(f.keypoints.size()), 0.9 * requested);
    EXPECT_LE(static_cast<int>(f.keypoints.size()), requested);
    std::vector<int> per_level(options.num_levels, 0);
    for (const Keypoint& kp : f.keypoints) {
      ASSERT_GE(kp.octave, 0);
      ASSERT_LT(kp.octave, options.num_levels);
      ++per_level[kp.octave];
      EXPECT_GE(kp.angle_deg, 0.f);
      EXPECT_LT(kp.angle_deg, 360.f);
      EXPECT_GE(kp.x, 0.f);
      EXPECT_GE(kp.y, 0.f);
      EXPECT_LT(kp.x, 640.f);
      EXPECT_LT(kp.y, 360.f);
    }
    for (int l = 0; l < options.num_levels; ++l) {
      EXPECT_LE(per_level[l], extractor.features_per_level()[l]) << "level " << l;
    }
    // Coarser levels get fewer features.
    EXPECT_GT(per_level[0], per_level[options.num_levels - 1]);
  }
}

TEST(OrbExtractor, EvenDistributionNoCellHogging) {
  // Left half high contrast, right half low contrast (still above the minimum threshold):
  // a strongest-N detector would put nearly all features on the left.
  cv::Mat image = MakeTexture(640, 360, 2, 1.0);
  const cv::Mat weak = MakeTexture(640, 360, 3, 0.12);
  weak(cv::Rect(320, 0, 320, 360)).copyTo(image(cv::Rect(320, 0, 320, 360)));
  OrbExtractorOptions options;
  options.num_features = 1000;
  OrbExtractor extractor(options);
  const Features f = Extract(extractor, image);
  int right = 0;
  // 4x4 grid over level 0: no cell holds more than 3x its share.
  int grid[4][4] = {};
  int level0 = 0;
  for (const Keypoint& kp : f.keypoints) {
    right += kp.x >= 320.f;
    if (kp.octave != 0) continue;
    ++level0;
    ++grid[std::min(3, static_cast<int>(kp.y / 90))][std::min(3, static_cast<int>(kp.x / 160))];
  }
  RecordProperty("right_half", right);
  RecordProperty("total", static_cast<int>(f.keypoints.size()));
  EXPECT_GT(right, 0.3 * f.keypoints.size()) << right << " of " << f.keypoints.size();
  for (auto& row : grid) {
    for (int count : row) EXPECT_LE(count, 3 * level0 / 16);
  }
}

TEST(OrbExtractor, DeterministicAcrossRunsAndInstances) {
  const cv::Mat image = MakeTexture(640, 360, 4);
  OrbExtractorOptions options;
  OrbExtractor a(options), b(options);
  const Features first = Extract(a, image);
  const Features second = Extract(a, MakeTexture(640, 360, 5));  // reuse buffers in between
  (void)second;
  const Features third = Extract(a, image);
  const Features other = Extract(b, image);
  ASSERT_EQ(first.keypoints.size(), third.keypoints.size());
  ASSERT_EQ(first.keypoints.size(), other.keypoints.size());
  for (size_t i = 0; i < first.keypoints.size(); ++i) {
    EXPECT_EQ(first.keypoints[i].x, third.keypoints[i].x);
    EXPECT_EQ(first.keypoints[i].y, other.keypoints[i].y);
    EXPECT_EQ(first.keypoints[i].angle_deg, other.keypoints[i].angle_deg);
    EXPECT_EQ(first.descriptors[i], third.descriptors[i]);
    EXPECT_EQ(first.descriptors[i], other.descriptors[i]);
  }
}

// Rotating the image rotates the keypoints and their angles; descriptors still match, which is
// what the intensity-centroid orientation is for.
TEST(OrbExtractor, RotationInvariantMatching) {
  const cv::Mat base = MakeTexture(480, 480, 6);
  const double rotation_deg = 30.0;
  const cv::Point2f centre(239.5f, 239.5f);
  const cv::Mat affine = cv::getRotationMatrix2D(centre, rotation_deg, 1.0);
  cv::Mat rotated;
  cv::warpAffine(base, rotated, affine, base.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                 cv::Scalar(128));
  OrbExtractorOptions options;
  options.num_features = 1000;
  OrbExtractor extractor(options);
  const Features a = Extract(extractor, base);
  const Features b = Extract(extractor, rotated);

  int matched = 0, correct = 0, angle_consistent = 0;
  for (size_t i = 0; i < a.keypoints.size(); ++i) {
    int best = -1, best_distance = 257, second = 257;
    for (size_t j = 0; j < b.keypoints.size(); ++j) {
      const int d = HammingDistance(a.descriptors[i], b.descriptors[j]);
      if (d < best_distance) {
        second = best_distance;
        best_distance = d;
        best = static_cast<int>(j);
      } else if (d < second) {
        second = d;
      }
    }
    if (best < 0 || best_distance > 50 || best_distance > 0.8 * second) continue;
    ++matched;
    const cv::Point2f p(a.keypoints[i].x, a.keypoints[i].y);
    const double px = affine.at<double>(0, 0) * p.x + affine.at<double>(0, 1) * p.y +
                      affine.at<double>(0, 2);
    const double py = affine.at<double>(1, 0) * p.x + affine.at<double>(1, 1) * p.y +
                      affine.at<double>(1, 2);
    const double error = std::hypot(px - b.keypoints[best].x, py - b.keypoints[best].y);
    if (error < 3.0 * std::pow(1.2, a.keypoints[i].octave)) {
      ++correct;
      // OpenCV's rotation matrix turns counter-clockwise on screen: image angles (y down)
      // decrease by rotation_deg.
      double delta = a.keypoints[i].angle_deg - b.keypoints[best].angle_deg;
      delta = std::fmod(delta + 720.0, 360.0);
      if (std::abs(delta - rotation_deg) < 15.0) ++angle_consistent;
    }
  }
  RecordProperty("matched", matched);
  RecordProperty("correct", correct);
  RecordProperty("angle_consistent", angle_consistent);
  EXPECT_GT(matched, 150) << "matched " << matched;
  EXPECT_GT(correct, 0.85 * matched) << correct << " of " << matched;
  EXPECT_GT(angle_consistent, 0.85 * correct) << angle_consistent << " of " << correct;
}

TEST(OrbExtractor, MasksRespected) {
  const cv::Mat image = MakeTexture(640, 360, 7);
  {
    cv::Mat mask(360, 640, CV_8UC1, cv::Scalar(255));
    mask(cv::Rect(0, 0, 320, 360)).setTo(0);  // left half forbidden
    OrbExtractor extractor(OrbExtractorOptions{});
    const Features f = Extract(extractor, image, mask);
    EXPECT_GT(f.keypoints.size(), 300u);
    for (const Keypoint& kp : f.keypoints) EXPECT_GE(kp.x, 319.5f);
  }
  {
    OrbExtractorOptions options;
    options.pole_mask_fraction = 0.2f;
    options.mask_rectangles.push_back({0.8f, 1.0f, 0.0f, 1.0f});
    OrbExtractor extractor(options);
    const Features f = Extract(extractor, image);
    EXPECT_GT(f.keypoints.size(), 300u);
    for (const Keypoint& kp : f.keypoints) {
      EXPECT_GE(kp.y, 0.2f * 360 - 0.5f);
      EXPECT_LE(kp.y, 0.8f * 360 + 0.5f);
      EXPECT_LE(kp.x, 0.8f * 640 + 0.5f);
    }
  }
}

TEST(OrbExtractor, ColorInputAndTinyOrBlankImages) {
  const cv::Mat gray = MakeTexture(320, 240, 8);
  cv::Mat color;
  cv::cvtColor(gray, color, cv::COLOR_GRAY2BGR);
  OrbExtractor extractor(OrbExtractorOptions{});
  const Features from_gray = Extract(extractor, gray);
  const Features from_color = Extract(extractor, color);
  ASSERT_EQ(from_gray.keypoints.size(), from_color.keypoints.size());
  EXPECT_EQ(from_gray.descriptors, from_color.descriptors);

  EXPECT_TRUE(Extract(extractor, cv::Mat(20, 20, CV_8UC1, cv::Scalar(0))).keypoints.empty());
  EXPECT_TRUE(Extract(extractor, cv::Mat(240, 320, CV_8UC1, cv::Scalar(90))).keypoints.empty());
  std::vector<Keypoint> k;
  std::vector<OrbDescriptor> d;
  EXPECT_THROW(extractor.Extract(cv::Mat(10, 10, CV_32F), cv::Mat(), &k, &d), std::logic_error);
  EXPECT_THROW(extractor.Extract(gray, cv::Mat(5, 5, CV_8UC1), &k, &d), std::logic_error);
}

TEST(OrbExtractor, OptionsProblems) {
  OrbExtractorOptions options;
  EXPECT_FALSE(options.Problem().has_value());
  options.scale_factor = 1.0f;
  EXPECT_TRUE(options.Problem().has_value());
  EXPECT_THROW(OrbExtractor{options}, std::logic_error);
  options = OrbExtractorOptions{};
  options.min_fast_threshold = 30;  // above the initial threshold
  EXPECT_TRUE(options.Problem().has_value());
  options = OrbExtractorOptions{};
  options.mask_rectangles.push_back({0.5f, 0.2f, 0.f, 1.f});
  EXPECT_NE(options.Problem()->find("mask_rectangles"), std::string::npos);
}

TEST(OrbExtractor, KittiFrameGivesRequestedCount) {
  const std::string path = std::string(LCV_SHARED_DIR) + "/data/kitti00/image_0/000000.png";
  const cv::Mat image = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (image.empty()) GTEST_SKIP() << "KITTI 00 not found at " << path;
  OrbExtractorOptions options;
  options.num_features = 2000;
  OrbExtractor extractor(options);
  const Features f = Extract(extractor, image);
  EXPECT_GE(static_cast<int>(f.keypoints.size()), 1900);
}

}  // namespace
}  // namespace lcv::slam
