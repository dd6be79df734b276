#include "privacy/information_attack.h"

#include <gtest/gtest.h>

#include <algorithm>

#include "mapping/line_cloud.h"
#include "privacy/reference_match.h"
#include "tests/privacy/line_cloud_fixture.h"

namespace lcv::privacy {
namespace {

// The covariance `lcv slam` writes into its map files: isotropic, one pixel's angle at the
// point's distance from the first keyframe that observed it.
slam::Map WithEngineCovariances(slam::Map points) {
  const double pixel_angle = 1.0 / points.cameras.begin()->second.fx;
  for (auto& [id, p] : points.points) {
    const slam::Keyframe& first = points.keyframes.at(p.observations.front().keyframe_id);
    const double sigma = pixel_angle * (p.position - first.cam_from_world.Center()).norm();
    p.covariance = sigma * sigma * Eigen::Matrix3d::Identity();
  }
  return points;
}

double RecoveredWithin(const LineAttackResult& result, const ReferenceMatch& match,
                       double tolerance) {
  int recovered = 0;
  for (std::size_t i = 0; i < result.size(); ++i) {
    recovered += match.matched[i] && result.has_estimate[i] &&
                 (result.estimates[i] - match.hidden_points[i]).norm() <= tolerance;
  }
  return static_cast<double>(recovered) / static_cast<double>(result.size());
}

mapping::LineCloudOptions Rule(mapping::LineInformationRule rule) {
  mapping::LineCloudOptions o;
  o.seed = 21;
  o.information = rule;
  return o;
}

// Eq. (1) from such a covariance: the line's sigma is the distance from the first keyframe, the
// hidden point is one of at most two points per keyframe, and the attack finds many exactly.
TEST(InformationAttack, RecoversPointsFromEquationOneInformation) {
  const slam::Map points = WithEngineCovariances(testing::MakeStreetPointMap(1500, 17));
  const slam::Map lines = mapping::ConvertToLineCloud(
      points, Rule(mapping::LineInformationRule::kPointCovariance));
  const LineAttackResult result = RunInformationAttack(lines);
  ASSERT_EQ(result.name, "information");
  ASSERT_EQ(result.size(), lines.lines.size());
  const ReferenceMatch match = MatchReference(lines, points);
  const double recovered = RecoveredWithin(result, match, 1e-6 * match.scene_scale);
  EXPECT_GT(recovered, 0.3) << "exact recoveries";
  // Risk is 1 / (number of candidates kept).
  for (std::size_t i = 0; i < result.size(); ++i) {
    if (result.has_estimate[i]) {
      EXPECT_GT(result.risk[i], 0.0);
      EXPECT_LE(result.risk[i], 1.0);
    }
  }
}

// The default rule makes Omega_L from the line and keyframes alone: nothing to read.
TEST(InformationAttack, DefaultPublishingLeavesNothingToRead) {
  const slam::Map points = WithEngineCovariances(testing::MakeStreetPointMap(1500, 17));
  const slam::Map lines =
      mapping::ConvertToLineCloud(points, Rule(mapping::LineInformationRule::kProxyPoint));
  const LineAttackResult result = RunInformationAttack(lines);
  const ReferenceMatch match = MatchReference(lines, points);
  EXPECT_LT(RecoveredWithin(result, match, 0.01 * match.scene_scale), 0.01);
  // Every line's Omega_L is the published rule's: the attack recognizes it and skips them all.
  for (unsigned char e : result.has_estimate) EXPECT_FALSE(e);
}

// A line with no information or seen by no keyframe gets no estimate.
TEST(InformationAttack, NoEstimateWithoutInformationOrKeyframes) {
  slam::Map lines = mapping::ConvertToLineCloud(
      WithEngineCovariances(testing::MakeStreetPointMap(50, 3)),
      Rule(mapping::LineInformationRule::kPointCovariance));
  auto it = lines.lines.begin();
  const slam::Id zero = it->first;
  it->second.information.setZero();
  const slam::Id unseen = (++it)->first;
  it->second.server_keyframe_ids.clear();
  for (auto& [kid, kf] : lines.server_keyframes) {
    kf.line_ids.erase(std::remove(kf.line_ids.begin(), kf.line_ids.end(), unseen),
                      kf.line_ids.end());
  }
  const LineAttackResult result = RunInformationAttack(lines);
  for (std::size_t i = 0; i < result.size(); ++i) {
    if (result.line_ids[i] == zero || result.line_ids[i] == unseen) {
      EXPECT_FALSE(result.has_estimate[i]);
      EXPECT_EQ(result.risk[i], 0.0);
    }
  }
}

}  // namespace
}  // namespace lcv::privacy
