#include "slam/util/approx_atan2.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace lcv::slam {
namespace {

TEST(ApproxAtan2Test, WithinTwoTenthsOfANanoradianEverywhere) {
  // Dense angles over the whole circle (every octant and the reduction's seam at tan(pi/8)),
  // each at several radii.
  double worst = 0.0;
  for (int k = 0; k <= 200000; ++k) {
    const double angle = -M_PI + 2.0 * M_PI * k / 200000.0;
    for (const double radius : {1e-6, 1.0, 3.7, 1e6}) {
      const double y = radius * std::sin(angle), x = radius * std::cos(angle);
      worst = std::max(worst, std::abs(ApproxAtan2(y, x) - std::atan2(y, x)));
    }
  }
  EXPECT_LT(worst, 2e-10);
  // Random ratios near the seam of the range reduction and near the diagonals.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> near_seam(0.41, 0.42), near_one(0.999, 1.001);
  for (int i = 0; i < 100000; ++i) {
    const double a = near_seam(rng), b = near_one(rng);
    for (const double sy : {-1.0, 1.0}) {
      for (const double sx : {-1.0, 1.0}) {
        EXPECT_NEAR(ApproxAtan2(sy * a, sx), std::atan2(sy * a, sx), 2e-10);
        EXPECT_NEAR(ApproxAtan2(sy, sx * a), std::atan2(sy, sx * a), 2e-10);
        EXPECT_NEAR(ApproxAtan2(sy * b, sx), std::atan2(sy * b, sx), 2e-10);
      }
    }
  }
}

TEST(ApproxAtan2Test, AxesAndOrigin) {
  EXPECT_DOUBLE_EQ(ApproxAtan2(0.0, 1.0), 0.0);
  EXPECT_NEAR(ApproxAtan2(1.0, 0.0), M_PI / 2, 1e-15);
  EXPECT_NEAR(ApproxAtan2(-2.0, 0.0), -M_PI / 2, 1e-15);
  EXPECT_NEAR(ApproxAtan2(0.0, -3.0), M_PI, 1e-15);
  EXPECT_NEAR(ApproxAtan2(1.0, 1.0), M_PI / 4, 2e-10);
  EXPECT_NEAR(ApproxAtan2(-1.0, -1.0), -3 * M_PI / 4, 2e-10);
  EXPECT_EQ(ApproxAtan2(0.0, 0.0), 0.0);
}

}  // namespace
}  // namespace lcv::slam
