#pragma once
// Check 2, direction randomness: a line cloud hides its points only if the line directions are
// uniform on the sphere and independent of the scene. Tests (each a p-value; the check fails when
// any p-value is below alpha / number of tests, Bonferroni):
// - Rayleigh (signed directions: a preferred direction) and Bingham (axial, d ~ -d: concentration
//   around an axis or a great circle), see privacy/statistics.h;
// - for each scene axis n, Kolmogorov-Smirnov of |d . n| against Uniform(0, 1), its law for
//   uniform d. Scene axes: the dominant plane normals of a reference point map (sequential
//   RANSAC), and the mean right / down / viewing axes of the server keyframes (the normals of the
//   ground and facades in a typical capture).

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "slam/data/map.h"

namespace lcv::privacy {

struct DirectionCheckOptions {
  double alpha = 1e-3;  // family-wise false-alarm rate
  int max_planes = 3;
  double plane_inlier_fraction = 0.01;  // of the reference extent: RANSAC inlier distance
  double min_plane_support = 0.05;      // of the reference points
  int ransac_iterations = 500;
  std::uint64_t seed = 0;
};

struct DirectionTest {
  std::string name;    // "rayleigh", "bingham", "ks_plane_normal_0", "ks_keyframe_down", ...
  double statistic = 0.0;
  double p_value = 1.0;
  int count = 0;
  Eigen::Vector3d axis = Eigen::Vector3d::Zero();  // for the KS tests
};

struct DirectionCheckResult {
  bool passed = true;
  double alpha_per_test = 0.0;
  std::vector<DirectionTest> tests;
};

// reference may be null. Fewer than 8 lines: passed, no tests (nothing to test).
DirectionCheckResult CheckDirections(const slam::Map& map, const slam::Map* reference,
                                     const DirectionCheckOptions& options = {});

// Dominant plane normals of points by sequential RANSAC (deterministic for a seed); used above
// and exposed for tests.
std::vector<Eigen::Vector3d> DominantPlaneNormals(const std::vector<Eigen::Vector3d>& points,
                                                  const DirectionCheckOptions& options);

}  // namespace lcv::privacy
