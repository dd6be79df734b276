#include "slam/data/frame.h"

#include <algorithm>
#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace lcv::slam {
namespace {

TEST(ScaleLevelsTest, ScalesAndPrediction) {
  const ScaleLevels levels(1.2, 8);
  EXPECT_EQ(levels.num_levels(), 8);
  EXPECT_DOUBLE_EQ(levels.Scale(0), 1.0);
  EXPECT_NEAR(levels.Scale(3), 1.728, 1e-12);
  EXPECT_NEAR(levels.InverseSigma2(2), 1.0 / (1.44 * 1.44), 1e-12);
  EXPECT_DOUBLE_EQ(levels.Scale(-3), 1.0);            // clamped
  EXPECT_DOUBLE_EQ(levels.Scale(20), levels.Scale(7));  // clamped
  // A landmark whose range ends at 10 m is seen at octave 0 from 10 m, finer from closer.
  EXPECT_EQ(levels.PredictOctave(10.0, 10.0), 0);
  EXPECT_EQ(levels.PredictOctave(10.0 / 1.2, 10.0), 1);
  EXPECT_EQ(levels.PredictOctave(10.0 / 1.2 / 1.2 - 1e-6, 10.0), 3);
  EXPECT_EQ(levels.PredictOctave(0.001, 10.0), 7);
  EXPECT_EQ(levels.PredictOctave(100.0, 10.0), 0);
  EXPECT_THROW(ScaleLevels(1.0, 8), std::logic_error);
}

TEST(KeypointGridTest, QueryMatchesBruteForce) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<float> ux(-5.f, 645.f), uy(-5.f, 485.f);
  std::uniform_int_distribution<int> octave(0, 7);
  std::vector<Keypoint> keypoints(3000);
  for (auto& kp : keypoints) {
    kp.x = ux(rng);
    kp.y = uy(rng);
    kp.octave = octave(rng);
  }
  KeypointGrid grid;
  grid.Build(keypoints, 640, 480, 32);
  std::vector<int> got;
  for (int q = 0; q < 200; ++q) {
    const float cx = ux(rng), cy = uy(rng);
    const float radius = 1.f + 40.f * (q % 7);
    const int min_octave = q % 3;
    const int max_octave = q % 5 == 0 ? -1 : min_octave + 2;
    grid.Query(keypoints, cx, cy, radius, min_octave, max_octave, &got);
    std::vector<int> expected;
    for (int i = 0; i < static_cast<int>(keypoints.size()); ++i) {
      const Keypoint& kp = keypoints[i];
      if (kp.octave < min_octave || (max_octave >= 0 && kp.octave > max_octave)) continue;
      if (std::abs(kp.x - cx) <= radius && std::abs(kp.y - cy) <= radius) expected.push_back(i);
    }
    std::sort(got.begin(), got.end());
    EXPECT_EQ(got, expected) << "query " << q;
  }
}

TEST(KeypointGridTest, EmptyFrame) {
  KeypointGrid grid;
  std::vector<Keypoint> none;
  grid.Build(none, 100, 100, 16);
  std::vector<int> got{1, 2};
  grid.Query(none, 50.f, 50.f, 30.f, 0, -1, &got);
  EXPECT_TRUE(got.empty());
}

}  // namespace
}  // namespace lcv::slam
