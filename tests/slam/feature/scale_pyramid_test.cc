#include "slam/feature/scale_pyramid.h"

#include <gtest/gtest.h>

namespace lcv::slam {
namespace {

TEST(ScalePyramid, ScalesAndSigmas) {
  const ScalePyramid pyramid(1.2f, 8);
  EXPECT_FLOAT_EQ(pyramid.Scale(0), 1.f);
  EXPECT_NEAR(pyramid.Scale(3), 1.728f, 1e-5);
  EXPECT_NEAR(pyramid.Sigma2(2), 1.44f * 1.44f, 1e-5);
  EXPECT_NEAR(pyramid.InvSigma2(1) * pyramid.Sigma2(1), 1.f, 1e-6);
  const auto scales = pyramid.Scales();
  const auto sigma2 = pyramid.Sigma2s();
  ASSERT_EQ(scales.size(), 8u);
  for (int l = 0; l < 8; ++l) EXPECT_NEAR(sigma2[l], scales[l] * scales[l], 1e-5);
}

TEST(ScalePyramid, PredictLevel) {
  const ScalePyramid pyramid(1.2f, 8);
  // Same distance: same level. Twice as close: the feature looks bigger, ~log_1.2(2) = 3.8
  // levels up. Farther: finer levels, clamped at 0.
  EXPECT_EQ(pyramid.PredictLevel(10.0, 10.0, 2), 2);
  EXPECT_EQ(pyramid.PredictLevel(5.0, 10.0, 2), 6);
  EXPECT_EQ(pyramid.PredictLevel(100.0, 10.0, 2), 0);
  EXPECT_EQ(pyramid.PredictLevel(0.1, 10.0, 2), 7);
  EXPECT_EQ(pyramid.PredictLevel(0.0, 10.0, 3), 3);
}

}  // namespace
}  // namespace lcv::slam
