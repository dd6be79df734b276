// atan2 by a polynomial, for the equirectangular camera's projection, which hot loops call for
// many bearings (the line search's samples: two atan2 per sample were ~25% of its time with
// libm's atan2; motion-only BA's terms: the largest part of each term's cost).
//
// Range reduction: |y|, |x| ordered so that t = min / max is in [0, 1]; above tan(pi/8) the
// identity atan(t) = pi/4 + atan((t - 1) / (t + 1)) moves t into [-tan(pi/8), tan(pi/8)],
// where an odd polynomial of degree 11 (coefficients fitted to minimize the largest error on that
// interval) is within 1.2e-10 rad of atan; the quadrant is restored from the signs. The whole
// function stays within 2e-10 rad of std::atan2 (tests/slam/util/approx_atan2_test.cc): 2e-8 px
// on a 640-column panorama, far below any keypoint's accuracy, at about a quarter of the cost.
// Not bit-identical to std::atan2: use it where results need not match libm exactly.
#pragma once

#include <cmath>

namespace lcv::slam {

// atan2(y, x) in [-pi, pi]; 0 for (0, 0). Non-finite input gives a non-finite or meaningless
// result (callers test their input first, as for std::atan2's domain).
inline double ApproxAtan2(double y, double x) {
  constexpr double kTanPiOver8 = 0.41421356237309503;
  constexpr double kPiOver4 = 0.78539816339744831;
  constexpr double kPiOver2 = 1.5707963267948966;
  constexpr double kPi = 3.1415926535897932;
  const double ax = std::abs(x), ay = std::abs(y);
  const bool steep = ay > ax;
  const double num = steep ? ax : ay, den = steep ? ay : ax;
  if (!(den > 0.0)) return 0.0;
  double t = num / den;  // [0, 1]
  double offset = 0.0;
  if (t > kTanPiOver8) {
    t = (t - 1.0) / (t + 1.0);
    offset = kPiOver4;
  }
  const double u = t * t;
  const double poly =
      0.99999999631602221 +
      u * (-0.33333271617549487 +
           u * (0.19997039403931557 +
                u * (-0.1422437315166879 + u * (0.1048181461307137 + u * -0.058403412194923301))));
  double angle = offset + t * poly;  // atan(min / max), [0, pi/4]
  if (steep) angle = kPiOver2 - angle;
  if (x < 0.0) angle = kPi - angle;
  return y < 0.0 ? -angle : angle;
}

}  // namespace lcv::slam
