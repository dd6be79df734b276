#include "slam/match/epipolar_matcher.h"

#include <cmath>
#include <algorithm>
#include <limits>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "slam/geometry/so3.h"
#include "slam/match/projection_matcher.h"

namespace lcv::slam {

namespace {

// The epipolar prefilter, the hot loop of the search (n1 x n2 tests): writes to out, ascending,
// every k < n with |nx x[k] + ny y[k] + nz z[k]| <= tolerance[k] and returns their count. Four
// bearings per step with SSE2 (x86-64's baseline; the build has no -march), then the few near
// the plane are read off the comparison's bit mask. The sums are formed in the scalar
// expression's order, so the result is bit-for-bit the plain loop's (the tail and other
// targets). Before, a loop with a push_back ran scalar and reloaded the arrays: 70% of this
// function, and this function 13% of a 360-degree line client's run in `perf`, where many
// keypoints stay free.
int GatherNearPlane(const float* x, const float* y, const float* z, const float* tolerance,
                    int n, float nx, float ny, float nz, int* out) {
  int count = 0;
  int k = 0;
#if defined(__SSE2__)
  const __m128 vx = _mm_set1_ps(nx);
  const __m128 vy = _mm_set1_ps(ny);
  const __m128 vz = _mm_set1_ps(nz);
  const __m128 abs_mask = _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff));
  for (; k + 4 <= n; k += 4) {
    const __m128 sine = _mm_add_ps(
        _mm_add_ps(_mm_mul_ps(vx, _mm_loadu_ps(x + k)), _mm_mul_ps(vy, _mm_loadu_ps(y + k))),
        _mm_mul_ps(vz, _mm_loadu_ps(z + k)));
    int mask = _mm_movemask_ps(
        _mm_cmple_ps(_mm_and_ps(sine, abs_mask), _mm_loadu_ps(tolerance + k)));
    while (mask != 0) {
      out[count++] = k + __builtin_ctz(static_cast<unsigned>(mask));
      mask &= mask - 1;
    }
  }
#endif
  for (; k < n; ++k) {
    const float sine = nx * x[k] + ny * y[k] + nz * z[k];
    if (std::abs(sine) <= tolerance[k]) out[count++] = k;
  }
  return count;
}

}  // namespace

double RadiansPerPixel(const Camera& camera) {
  const Eigen::Vector2d center(0.5 * (camera.cols() - 1), 0.5 * (camera.rows() - 1));
  const auto a = camera.Unproject(center);
  const auto b = camera.Unproject(center + Eigen::Vector2d(1.0, 0.0));
  if (!a || !b) return 1.0 / 500.0;
  return std::acos(std::clamp(a->dot(*b), -1.0, 1.0));
}

int MatchForTriangulation(const SlamKeyframe& kf1, const SlamKeyframe& kf2,
                          const EpipolarMatchOptions& options,
                          std::vector<std::pair<int, int>>* matches) {
  matches->clear();
  // cam2_from_cam1 = (R, t): E = [t]x R maps a bearing of 1 to its epipolar plane normal in 2.
  const Rigid3d cam2_from_cam1 = kf2.cam_from_world * kf1.cam_from_world.Inverse();
  const Eigen::Matrix3d R = cam2_from_cam1.RotationMatrix();
  const Eigen::Vector3d t = cam2_from_cam1.translation;
  if (!(t.norm() > 0.0)) return 0;
  const Eigen::Matrix3d E = SkewSymmetric(t) * R;
  // Epipoles: centre of camera 1 seen from camera 2 (t direction), and of 2 seen from 1.
  const Eigen::Vector3d epipole2 = t.normalized();
  const Eigen::Vector3d epipole1 = -(R.transpose() * t).normalized();
  const double cos_epipole = std::cos(options.min_angle_to_epipole_rad);

  const int n1 = static_cast<int>(kf1.keypoints.size());
  const int n2 = static_cast<int>(kf2.keypoints.size());
  // Epipolar tolerance of each octave of kf2.
  std::vector<double> octave_tolerance(kf2.scale_levels.num_levels());
  for (int o = 0; o < static_cast<int>(octave_tolerance.size()); ++o) {
    octave_tolerance[o] = std::sin(options.sigma_factor * kf2.scale_levels.Scale(o) *
                                   options.radians_per_pixel);
  }
  const int last_octave = static_cast<int>(octave_tolerance.size()) - 1;
  // Free keypoints of kf2 with valid bearings, away from the epipole, with their bearings in
  // contiguous float arrays: the epipolar prefilter below is the hot loop (n1 x n2). Each has
  // its octave's tolerance, and a prefilter bound that adds float rounding, so that the
  // prefilter passes a superset of the exact test (the largest octave's bound for all, 3.6x
  // wider than most keypoints' own, let through mostly candidates the exact test rejected).
  std::vector<int> free2;
  std::vector<float> x2, y2, z2, prefilter_tolerance2;
  std::vector<double> tolerance2;
  free2.reserve(n2);
  for (int i2 = 0; i2 < n2; ++i2) {
    if (kf2.landmark_ids[i2] != kInvalidId) continue;
    const Eigen::Vector3d& f2 = kf2.bearings[i2];
    if (f2.squaredNorm() < 0.5 || std::abs(f2.dot(epipole2)) > cos_epipole) continue;
    free2.push_back(i2);
    x2.push_back(static_cast<float>(f2.x()));
    y2.push_back(static_cast<float>(f2.y()));
    z2.push_back(static_cast<float>(f2.z()));
    tolerance2.push_back(octave_tolerance[std::clamp(kf2.keypoints[i2].octave, 0, last_octave)]);
    prefilter_tolerance2.push_back(static_cast<float>(tolerance2.back()) + 1e-5f);
  }
  const int num_free2 = static_cast<int>(free2.size());
  std::vector<int> near_plane(num_free2);

  std::vector<int> match12(n1, -1);
  std::vector<int> match_distance2(n2, std::numeric_limits<int>::max());
  std::vector<int> matched_by2(n2, -1);
  for (int i1 = 0; i1 < n1; ++i1) {
    if (kf1.landmark_ids[i1] != kInvalidId) continue;
    const Eigen::Vector3d& f1 = kf1.bearings[i1];
    if (f1.squaredNorm() < 0.5 || std::abs(f1.dot(epipole1)) > cos_epipole) continue;
    Eigen::Vector3d normal = E * f1;
    const double normal_norm = normal.norm();
    if (!(normal_norm > 0.0)) continue;
    normal /= normal_norm;
    const float nx = static_cast<float>(normal.x());
    const float ny = static_cast<float>(normal.y());
    const float nz = static_cast<float>(normal.z());
    const int num_near = GatherNearPlane(x2.data(), y2.data(), z2.data(),
                                         prefilter_tolerance2.data(), num_free2, nx, ny, nz,
                                         near_plane.data());
    NearestTwo nearest;
    for (int n = 0; n < num_near; ++n) {
      const int k = near_plane[n];
      const int i2 = free2[k];
      const double sine = std::abs(normal.dot(kf2.bearings[i2]));
      if (sine > tolerance2[k]) continue;
      const int d = HammingDistance(kf1.descriptors[i1], kf2.descriptors[i2]);
      if (d > options.max_hamming_distance) continue;
      nearest.Offer(d, i2);
    }
    const int best = nearest.best, second = nearest.second, best_index = nearest.index;
    if (best_index < 0) continue;
    if (second != NearestTwo::kNone && best >= options.ratio * second) continue;
    if (best >= match_distance2[best_index]) continue;
    if (matched_by2[best_index] >= 0) match12[matched_by2[best_index]] = -1;
    match12[i1] = best_index;
    matched_by2[best_index] = i1;
    match_distance2[best_index] = best;
  }

  std::vector<unsigned char> keep;
  std::vector<std::vector<int>> bins;
  if (options.check_orientation) {
    bins.resize(options.orientation_bins);
    for (int i1 = 0; i1 < n1; ++i1) {
      if (match12[i1] < 0) continue;
      const float a1 = kf1.keypoints[i1].angle_deg;
      const float a2 = kf2.keypoints[match12[i1]].angle_deg;
      if (a1 < 0.f || a2 < 0.f) continue;
      bins[RotationBin(a1, a2, options.orientation_bins)].push_back(i1);
    }
    keep = DominantRotationBins(bins);
    for (int b = 0; b < options.orientation_bins; ++b) {
      if (keep[b]) continue;
      for (const int i1 : bins[b]) match12[i1] = -1;
    }
  }
  for (int i1 = 0; i1 < n1; ++i1) {
    if (match12[i1] >= 0) matches->emplace_back(i1, match12[i1]);
  }
  return static_cast<int>(matches->size());
}

}  // namespace lcv::slam
