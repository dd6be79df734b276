#include "slam/solve/two_view.h"

#include <random>

#include <gtest/gtest.h>

#include "tests/slam/solve/solve_test_util.h"

namespace lcv::slam {
namespace {

struct Scene {
  Rigid3d cam2_from_cam1;
  std::vector<Eigen::Vector3d> points_in_cam1;
  std::vector<Eigen::Vector3d> bearings1, bearings2;
  std::vector<char> is_inlier;
};

// planar: points on a plane facing the camera (a wall); otherwise a volume of depth 4..12.
Scene MakeScene(std::uint64_t seed, int n, double noise_rad, double outlier_ratio, bool planar,
                double baseline = 0.5) {
  std::mt19937_64 rng(seed);
  Scene scene;
  const Eigen::Vector3d direction =
      (Eigen::Vector3d(1, 0, 0) + 0.3 * test::RandomUnit(rng)).normalized();
  scene.cam2_from_cam1 = Rigid3d(test::RandomRotation(rng, 0.1), -baseline * direction);
  std::uniform_real_distribution<double> uniform(-0.6, 0.6);
  while (static_cast<int>(scene.bearings1.size()) < n) {
    Eigen::Vector3d p1;
    if (planar) {
      // A ground-like plane tilted 40 degrees from fronto-parallel, 6 units ahead.
      const Eigen::Vector3d normal(0.0, -std::sin(0.7), std::cos(0.7));
      const Eigen::Vector3d ray(uniform(rng), uniform(rng), 1.0);
      p1 = ray * (6.0 / normal.dot(ray));
    } else {
      p1 = test::RandomPointInView(rng, 0.6, 4.0, 12.0);
    }
    const Eigen::Vector3d p2 = scene.cam2_from_cam1 * p1;
    if (p2.z() < 1.0) continue;
    const bool outlier = scene.bearings1.size() < outlier_ratio * n;
    scene.points_in_cam1.push_back(p1);
    scene.bearings1.push_back(test::PerturbBearing(p1, noise_rad, rng));
    Eigen::Vector3d b2 = test::PerturbBearing(p2, noise_rad, rng);
    if (outlier) b2 = test::PerturbBearing(p2, 0.05 + 0.1 * uniform(rng) * uniform(rng), rng);
    scene.bearings2.push_back(b2);
    scene.is_inlier.push_back(!outlier);
  }
  return scene;
}

void ExpectRecovered(const Scene& scene, const TwoViewGeometry& result, double angle_tol,
                     double point_tol, double noise_rad) {
  ASSERT_TRUE(result.success) << result.reason;
  EXPECT_LT(AngularDistance(result.cam2_from_cam1.rotation, scene.cam2_from_cam1.rotation),
            angle_tol);
  EXPECT_LT(test::TranslationAngle(result.cam2_from_cam1.translation,
                                   scene.cam2_from_cam1.translation),
            angle_tol * 5);
  EXPECT_NEAR(result.cam2_from_cam1.translation.norm(), 1.0, 1e-9);
  // Points come out in the frame of camera 1 at the scale |t| = 1.
  const double scale = 1.0 / scene.cam2_from_cam1.translation.norm();
  int outliers_triangulated = 0;
  for (size_t i = 0; i < scene.bearings1.size(); ++i) {
    if (!result.triangulated[i]) continue;
    if (!scene.is_inlier[i]) {
      ++outliers_triangulated;
      continue;
    }
    const Eigen::Vector3d truth = scene.points_in_cam1[i] * scale;
    // Depth error grows as (bearing noise) / parallax: 10 sigma, at least point_tol.
    const Eigen::Vector3d centre2 = scene.cam2_from_cam1.Inverse().translation * scale;
    const double parallax = test::TranslationAngle(truth, truth - centre2);
    const double tolerance = std::max(point_tol, 10.0 * noise_rad / parallax);
    EXPECT_LT((result.points_in_cam1[i] - truth).norm(), tolerance * truth.norm());
  }
  // An outlier displaced along its epipolar line is consistent with the motion and cannot be
  // told apart; the simulated outliers are displaced in random directions, so few are.
  EXPECT_LE(outliers_triangulated, static_cast<int>(0.1 * scene.bearings1.size()));
}

TEST(TwoView, GeneralSceneChoosesEssential) {
  for (std::uint64_t seed : {1u, 11u, 21u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const Scene scene = MakeScene(seed, 300, 5e-4, 0.3, false);
    TwoViewOptions options;
    options.random_seed = seed;
    const TwoViewGeometry result =
        EstimateTwoViewGeometry(scene.bearings1, scene.bearings2, options);
    ExpectRecovered(scene, result, 5e-3, 0.02, 5e-4);
    EXPECT_EQ(result.model, TwoViewGeometry::Model::kEssential);
    EXPECT_GE(result.num_triangulated, 180);
    EXPECT_GT(result.median_parallax_deg, 1.0);
  }
}

TEST(TwoView, PlanarSceneChoosesHomography) {
  for (std::uint64_t seed : {2u, 12u, 22u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const Scene scene = MakeScene(seed, 300, 5e-4, 0.3, true);
    TwoViewOptions options;
    options.random_seed = seed;
    const TwoViewGeometry result =
        EstimateTwoViewGeometry(scene.bearings1, scene.bearings2, options);
    ExpectRecovered(scene, result, 5e-3, 0.02, 5e-4);
    EXPECT_EQ(result.model, TwoViewGeometry::Model::kHomography);
  }
}

TEST(TwoView, ExactDataRecoversTruth) {
  const Scene scene = MakeScene(3, 100, 0.0, 0.0, false);
  TwoViewOptions options;
  options.use_homography = false;
  const TwoViewGeometry result = EstimateTwoViewGeometry(scene.bearings1, scene.bearings2, options);
  ExpectRecovered(scene, result, 1e-8, 1e-7, 0.0);
  EXPECT_EQ(result.num_triangulated, 100);
}

TEST(TwoView, FailsWithoutParallaxOrData) {
  TwoViewOptions options;
  // Tiny baseline: rotation only, in effect.
  const Scene scene = MakeScene(4, 300, 5e-4, 0.0, false, 0.005);
  const TwoViewGeometry result = EstimateTwoViewGeometry(scene.bearings1, scene.bearings2, options);
  EXPECT_FALSE(result.success);
  EXPECT_FALSE(result.reason.empty());
  const std::vector<Eigen::Vector3d> few(5, Eigen::Vector3d::UnitZ());
  const TwoViewGeometry none = EstimateTwoViewGeometry(few, few, options);
  EXPECT_FALSE(none.success);
  EXPECT_NE(none.reason.find("too few"), std::string::npos);
}

// Forward motion (a car): most points far ahead with little parallax, a few near ones with a
// lot. Returns the pairs; near points first.
Scene MakeForwardScene(std::uint64_t seed, int num_near, int num_far) {
  std::mt19937_64 rng(seed);
  Scene scene;
  scene.cam2_from_cam1 = Rigid3d(test::RandomRotation(rng, 0.02), Eigen::Vector3d(0, 0, -0.5));
  const double noise_rad = 2e-4;
  for (int i = 0; i < num_near + num_far; ++i) {
    const bool near = i < num_near;
    const Eigen::Vector3d p1 =
        near ? test::RandomPointInView(rng, 0.6, 4.0, 8.0) : test::RandomPointInView(rng, 0.6, 40.0, 80.0);
    const Eigen::Vector3d p2 = scene.cam2_from_cam1 * p1;
    scene.points_in_cam1.push_back(p1);
    scene.bearings1.push_back(test::PerturbBearing(p1, noise_rad, rng));
    scene.bearings2.push_back(test::PerturbBearing(p2, noise_rad, rng));
    scene.is_inlier.push_back(1);
  }
  return scene;
}

// The parallax gate is ORB-SLAM's: parallax_rank points above the threshold, not the median
// (which forward motion keeps low while the near points already fix the motion).
TEST(TwoView, ForwardMotionInitializesOnItsNearPoints) {
  TwoViewOptions options;
  options.use_homography = false;
  options.random_seed = 3;
  const Scene enough = MakeForwardScene(6, 120, 400);
  const TwoViewGeometry result = EstimateTwoViewGeometry(enough.bearings1, enough.bearings2, options);
  ASSERT_TRUE(result.success) << result.reason;
  EXPECT_LT(result.median_parallax_deg, options.parallax_threshold_deg);
  EXPECT_GE(result.ranked_parallax_deg, options.parallax_threshold_deg);
  EXPECT_LT(AngularDistance(result.cam2_from_cam1.rotation, enough.cam2_from_cam1.rotation), 2e-3);
  EXPECT_LT(test::TranslationAngle(result.cam2_from_cam1.translation,
                                   enough.cam2_from_cam1.translation),
            0.05);

  // Fewer near points than the rank: not enough parallax to trust, wait (even when fewer
  // triangulated points would do).
  options.min_num_triangulated = 20;
  const Scene too_few = MakeForwardScene(7, 30, 400);
  const TwoViewGeometry waiting =
      EstimateTwoViewGeometry(too_few.bearings1, too_few.bearings2, options);
  EXPECT_FALSE(waiting.success);
  EXPECT_NE(waiting.reason.find("parallax"), std::string::npos) << waiting.reason;
}

TEST(TwoView, DeterministicForSeed) {
  const Scene scene = MakeScene(5, 200, 1e-3, 0.3, false);
  TwoViewOptions options;
  options.random_seed = 42;
  const auto a = EstimateTwoViewGeometry(scene.bearings1, scene.bearings2, options);
  const auto b = EstimateTwoViewGeometry(scene.bearings1, scene.bearings2, options);
  ASSERT_TRUE(a.success) << a.reason;
  EXPECT_EQ(a.cam2_from_cam1.translation, b.cam2_from_cam1.translation);
  EXPECT_EQ(a.inlier_mask, b.inlier_mask);
}

}  // namespace
}  // namespace lcv::slam
