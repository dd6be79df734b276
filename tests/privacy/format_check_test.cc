#include "privacy/format_check.h"

#include <gtest/gtest.h>

#include "tests/privacy/line_cloud_fixture.h"

namespace lcv::privacy {
namespace {

class FormatCheckTest : public ::testing::Test {
 protected:
  void SetUp() override {
    points_ = testing::MakeStreetPointMap(2000, 41);
    lines_ = testing::MakeLineCloud(points_, 41);
  }
  slam::Map points_, lines_;
};

TEST_F(FormatCheckTest, CleanLineCloudPasses) {
  const ReferenceMatch match = MatchReference(lines_, points_);
  const FormatCheckResult r = CheckFormat(lines_, &match);
  EXPECT_TRUE(r.passed) << (r.problems.empty() ? "" : r.problems[0]);
  EXPECT_TRUE(r.has_reference_test);
  EXPECT_GT(r.anchor_ks_p_value, 1e-3);
}

// Planted leak: a file with restored points X'.
TEST_F(FormatCheckTest, RestoredPointsFail) {
  int k = 0;
  for (auto& [id, l] : lines_.lines) {
    if (k++ < 5) l.restored_point = points_.points.at(id).position;
  }
  const FormatCheckResult r = CheckFormat(lines_, nullptr);
  EXPECT_FALSE(r.passed);
  EXPECT_EQ(r.num_restored_points, 5);
  ASSERT_EQ(r.problems.size(), 1u);
  EXPECT_NE(r.problems[0].find("restored points X'"), std::string::npos);
}

TEST_F(FormatCheckTest, PointsAndKeyframesFail) {
  lines_.points = points_.points;
  lines_.keyframes = points_.keyframes;
  const FormatCheckResult r = CheckFormat(lines_, nullptr);
  EXPECT_FALSE(r.passed);
  EXPECT_EQ(r.num_points, 2000);
  EXPECT_GT(r.num_keypoints, 0);
}

// Planted leak: anchors at the hidden points (the rule broken).
TEST_F(FormatCheckTest, AnchorsAtPointsFail) {
  for (auto& [id, l] : lines_.lines) l.line.anchor = points_.points.at(id).position;
  const ReferenceMatch match = MatchReference(lines_, points_);
  const FormatCheckResult r = CheckFormat(lines_, &match);
  EXPECT_FALSE(r.passed);
  EXPECT_GT(r.num_anchor_rule_violations, 1900);
  EXPECT_EQ(r.num_anchors_at_point, 2000);
}

// Subtler: anchors follow the rule but directions are chosen so that the point sits near the
// anchor (d nearly orthogonal to X): only the statistical test sees it.
TEST_F(FormatCheckTest, DirectionsTiedToPointsFailWithReference) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (auto& [id, l] : lines_.lines) {
    const Eigen::Vector3d x = points_.points.at(id).position;
    Eigen::Vector3d d = slam::UniformUnitVector(u(rng), u(rng));
    d = (d - 0.7 * d.dot(x.normalized()) * x.normalized()).normalized();
    l.line = slam::Line3d(x - d.dot(x) * d, d);
  }
  const ReferenceMatch match = MatchReference(lines_, points_);
  const FormatCheckResult r = CheckFormat(lines_, &match);
  EXPECT_EQ(r.num_anchor_rule_violations, 0);
  EXPECT_LT(r.anchor_ks_p_value, 1e-6);
  EXPECT_FALSE(r.passed);
  EXPECT_TRUE(CheckFormat(lines_, nullptr).passed) << "invisible without the reference";
}

}  // namespace
}  // namespace lcv::privacy
