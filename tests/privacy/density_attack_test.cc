#include "privacy/density_attack.h"

#include <random>

#include <gtest/gtest.h>

#include "privacy/reference_match.h"
#include "tests/privacy/line_cloud_fixture.h"

namespace lcv::privacy {
namespace {

// On the synthetic street the attack must do far better than chance: a uniform guess inside the
// scene box is within 1% of the scene scale for ~0.01% of the lines.
TEST(DensityAttack, RecoversStreetPoints) {
  const std::uint64_t seed = 21;
  const slam::Map points = testing::MakeStreetPointMap(8000, seed);
  const slam::Map lines = testing::MakeLineCloud(points, seed);
  const LineAttackResult result = RunDensityAttack(lines);
  ASSERT_EQ(result.size(), lines.lines.size());
  const ReferenceMatch match = MatchReference(lines, points);
  ASSERT_EQ(match.matched_by_id, 8000);
  const RecoveryStats stats = EvaluateRecovery(result, match, {{0.01, true}, {0.5, false}});
  EXPECT_GT(stats.fractions[0], 0.25) << "seed " << seed;
  EXPECT_GT(stats.fractions[1], 0.15) << "seed " << seed;
  for (double r : result.risk) {
    EXPECT_GE(r, 0.0);
    EXPECT_LE(r, 1.0);
  }
}

// Planted leak: a tight cluster of points (a small textured object) inside a sparse scene. Its
// lines all meet near the cluster, which the attack must find, with high risk.
TEST(DensityAttack, FindsPlantedCluster) {
  const std::uint64_t seed = 4;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> g(0.0, 0.02);
  slam::Map points;
  slam::Id id = 1;
  const Eigen::Vector3d centre(1.0, 2.0, 3.0);
  for (int i = 0; i < 300; ++i, ++id) {
    points.points[id].id = id;
    points.points[id].position = centre + Eigen::Vector3d(g(rng), g(rng), g(rng));
  }
  for (int i = 0; i < 3000; ++i, ++id) {
    points.points[id].id = id;
    points.points[id].position = Eigen::Vector3d(10 * u(rng) - 5, 10 * u(rng) - 5, 10 * u(rng));
  }
  const slam::Map lines = testing::MakeLineCloud(points, seed + 1);
  const LineAttackResult result = RunDensityAttack(lines);
  const ReferenceMatch match = MatchReference(lines, points);
  int recovered = 0;
  double cluster_risk = 0.0, other_risk = 0.0;
  for (std::size_t i = 0; i < result.size(); ++i) {
    if (i < 300) {
      recovered += result.has_estimate[i] && (result.estimates[i] - match.hidden_points[i]).norm() < 0.1;
      cluster_risk += result.risk[i] / 300.0;
    } else {
      other_risk += result.risk[i] / 3000.0;
    }
  }
  EXPECT_GT(recovered, 270) << "seed " << seed;
  EXPECT_GT(cluster_risk, other_risk) << "seed " << seed;
}

TEST(DensityAttack, DegenerateInputs) {
  slam::Map empty;
  EXPECT_EQ(RunDensityAttack(empty).size(), 0u);
  slam::Map one;
  one.lines[5].line = slam::Line3d(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX());
  const LineAttackResult r = RunDensityAttack(one);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r.line_ids[0], 5u);
  EXPECT_FALSE(r.has_estimate[0]);
}

TEST(DensityAttack, ThreadCountDoesNotChangeResult) {
  const slam::Map points = testing::MakeStreetPointMap(2000, 9);
  const slam::Map lines = testing::MakeLineCloud(points, 9);
  DensityAttackOptions one, two;
  one.num_threads = 1;
  two.num_threads = 2;
  const LineAttackResult a = RunDensityAttack(lines, one);
  const LineAttackResult b = RunDensityAttack(lines, two);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a.has_estimate[i], b.has_estimate[i]);
    EXPECT_EQ(a.estimates[i], b.estimates[i]);
    EXPECT_EQ(a.risk[i], b.risk[i]);
  }
}

}  // namespace
}  // namespace lcv::privacy
