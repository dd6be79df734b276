#include "slam/module/initializer.h"

#include <gtest/gtest.h>

#include "slam/geometry/so3.h"
#include "tests/slam/match/matcher_test_util.h"

namespace lcv::slam {
namespace {

class InitializerTest : public ::testing::Test {
 protected:
  Frame Observe(int index, std::mt19937_64* rng) {
    testing::ObservationNoise noise;
    noise.clutter = 200;
    observed_.push_back(testing::ObserveScene(scene_, *camera_, poses_[index], noise, rng));
    return testing::MakeFrame(*camera_, observed_.back(), poses_[index], index);
  }
  std::unique_ptr<Camera> camera_ = MakeCamera(testing::SyntheticPinhole());
  testing::SyntheticScene scene_ = testing::MakeSlabScene(2000, -3.0, 4.0, 4.0, 9.0, 61);
  std::vector<Rigid3d> poses_ = testing::MakeLateralTrajectory(10, 0.1);
  std::vector<testing::SyntheticFrame> observed_;
};

TEST_F(InitializerTest, RecoversRelativePoseAndStructureUpToScale) {
  const std::uint64_t seed = 62;
  SCOPED_TRACE("seed " + std::to_string(seed));
  std::mt19937_64 rng(seed);
  InitializerOptions options;
  options.seed = seed;
  Initializer initializer(options);
  const Frame f0 = Observe(0, &rng);
  EXPECT_FALSE(initializer.TryInitialize(f0));  // becomes the reference
  EXPECT_TRUE(initializer.has_reference());
  std::optional<Initialization> init;
  int used = 0;
  for (int i = 1; i < 10 && !init; ++i) {
    init = initializer.TryInitialize(Observe(i, &rng));
    used = i;
  }
  ASSERT_TRUE(init) << initializer.last_failure();
  const Rigid3d truth = poses_[used] * poses_[0].Inverse();
  EXPECT_LT(AngularDistance(init->current_from_reference.rotation, truth.rotation), 5e-3);
  EXPECT_NEAR(init->current_from_reference.translation.norm(), 1.0, 1e-9);
  const double cos_t =
      init->current_from_reference.translation.dot(truth.translation.normalized());
  // Initialization happens as soon as the median parallax reaches 1 degree: with 0.5 px noise
  // at f = 500 px the baseline direction is good to a few degrees, depths to ~10%.
  EXPECT_GT(cos_t, 0.99) << "initialized at frame " << used;
  // Points: the true ones scaled by 1 / |t_truth|, mostly correct correspondences.
  const double scale = 1.0 / truth.translation.norm();
  ASSERT_GE(init->matches.size(), 50u);
  int good = 0;
  for (size_t k = 0; k < init->matches.size(); ++k) {
    const int j = observed_[0].point_index[init->matches[k].first];
    if (j < 0) continue;
    const Eigen::Vector3d expected = scale * (poses_[0] * scene_.points_in_world[j]);
    good += (init->points_in_reference[k] - expected).norm() < 0.25 * expected.norm();
  }
  EXPECT_GE(good, 0.9 * init->matches.size());
}

TEST_F(InitializerTest, NoMotionDoesNotInitialize) {
  std::mt19937_64 rng(63);
  Initializer initializer{InitializerOptions()};
  const Frame f0 = Observe(0, &rng);
  initializer.TryInitialize(f0);
  // The same pose again, re-observed with fresh noise: no parallax.
  std::mt19937_64 rng2(64);
  testing::SyntheticFrame again = testing::ObserveScene(scene_, *camera_, poses_[0], testing::ObservationNoise(), &rng2);
  EXPECT_FALSE(initializer.TryInitialize(testing::MakeFrame(*camera_, again, poses_[0], 1)));
  EXPECT_FALSE(initializer.last_failure().empty());
}

}  // namespace
}  // namespace lcv::slam
