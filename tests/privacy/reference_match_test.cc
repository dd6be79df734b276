#include "privacy/reference_match.h"

#include <gtest/gtest.h>

#include "tests/privacy/line_cloud_fixture.h"

namespace lcv::privacy {
namespace {

TEST(ReferenceMatch, ByIdAndByGeometry) {
  const slam::Map points = testing::MakeStreetPointMap(500, 2);
  slam::Map lines = testing::MakeLineCloud(points, 2);
  // Renumber half of the lines: they must be matched by the line through each point.
  slam::Map renumbered = lines;
  renumbered.lines.clear();
  int k = 0;
  for (const auto& [id, l] : lines.lines) {
    const slam::Id new_id = (k++ % 2) ? id : id + 1000000;
    renumbered.lines[new_id] = l;
    renumbered.lines[new_id].id = new_id;
  }
  const ReferenceMatch match = MatchReference(renumbered, points);
  EXPECT_EQ(match.num_matched(), 500);
  EXPECT_EQ(match.matched_by_id, 250);
  EXPECT_EQ(match.matched_by_geometry, 250);
  std::size_t i = 0;
  for (const auto& [id, l] : renumbered.lines) {
    ASSERT_TRUE(match.matched[i]);
    EXPECT_LT(l.line.Distance(match.hidden_points[i]), 1e-6);
    const slam::Id original = id >= 1000000 ? id - 1000000 : id;
    EXPECT_EQ(match.hidden_points[i], points.points.at(original).position);
    ++i;
  }
  EXPECT_GT(match.scene_scale, 10.0);
}

TEST(ReferenceMatch, RecoveryStatistics) {
  ReferenceMatch match;
  match.hidden_points = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(),
                         Eigen::Vector3d::Zero()};
  match.matched = {1, 1, 1, 0};
  match.matched_by_id = 3;
  match.scene_scale = 10.0;
  LineAttackResult attack;
  attack.Resize(4);
  attack.estimates[0] = Eigen::Vector3d(0.04, 0, 0);
  attack.estimates[1] = Eigen::Vector3d(0, 0.3, 0);
  attack.has_estimate = {1, 1, 0, 1};
  const RecoveryStats s = EvaluateRecovery(attack, match, {{0.05, false}, {0.05, true}});
  EXPECT_EQ(s.num_hidden_points, 3);
  EXPECT_EQ(s.num_estimated, 2);
  EXPECT_NEAR(s.fractions[0], 1.0 / 3, 1e-12);
  EXPECT_NEAR(s.fractions[1], 2.0 / 3, 1e-12);  // 5% of 10 = 0.5
  EXPECT_NEAR(s.tolerances_m[1], 0.5, 1e-12);
  EXPECT_NEAR(s.median_error_m, 0.3, 1e-12);
  EXPECT_EQ(Tolerance({0.1, false}).Label(), "0.1m");
  EXPECT_EQ(Tolerance({0.02, true}).Label(), "2%");
}

// Dropping lines (mitigation) must not shrink the denominator: the points of dropped lines are
// hidden points the attack did not recover.
TEST(ReferenceMatch, UnpublishedPointsCountAsNotRecovered) {
  const slam::Map points = testing::MakeStreetPointMap(400, 3);
  const slam::Map lines = testing::MakeLineCloud(points, 3);
  slam::Map published = lines;
  int dropped = 0;
  for (auto it = published.lines.begin(); it != published.lines.end();) {
    if (dropped < 100) {
      it = published.lines.erase(it);
      ++dropped;
    } else {
      ++it;
    }
  }
  for (auto& [id, kf] : published.server_keyframes) {
    std::vector<slam::Id> kept;
    for (slam::Id l : kf.line_ids) if (published.lines.count(l)) kept.push_back(l);
    kf.line_ids = kept;
  }
  const ReferenceMatch match = MatchReference(published, points);
  EXPECT_EQ(match.num_matched(), 300);
  EXPECT_EQ(match.num_reference_points, 400);
  EXPECT_EQ(match.num_unpublished(), 100);
  // A perfect attack on the published lines recovers 3/4 of the scene.
  LineAttackResult attack;
  attack.Resize(published.lines.size());
  for (std::size_t i = 0; i < published.lines.size(); ++i) {
    attack.estimates[i] = match.hidden_points[i];
    attack.has_estimate[i] = 1;
  }
  const RecoveryStats s = EvaluateRecovery(attack, match, {{0.01, false}});
  EXPECT_EQ(s.num_hidden_points, 400);
  EXPECT_NEAR(s.fractions[0], 0.75, 1e-12);
}

}  // namespace
}  // namespace lcv::privacy
