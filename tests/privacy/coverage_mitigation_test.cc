#include "privacy/coverage_mitigation.h"

#include <gtest/gtest.h>

#include "privacy/mitigation.h"
#include "slam/camera/camera.h"
#include "slam/geometry/line3.h"
#include "tests/slam/system/synthetic_features.h"

namespace lcv::privacy {
namespace {

// A 640 x 480 pinhole camera (f 500 px): the 4 x 4 guard grid has cells of 160 x 120 px.
slam::CameraParams Pinhole() { return slam::testing::SyntheticPinhole(); }

// The world point imaged at pixel (u, v) at depth 10 by a keyframe with cam_from_world = a
// translation by -centre (identity rotation).
Eigen::Vector3d PointAt(double u, double v, const Eigen::Vector3d& centre) {
  const slam::CameraParams c = Pinhole();
  return centre + 10.0 * Eigen::Vector3d((u - c.cx) / c.fx, (v - c.cy) / c.fy, 1.0);
}

class CoverageMitigationTest : public ::testing::Test {
 protected:
  // Keyframe A (id 1) at the origin sees 3 lines in each of its 16 cells (48 lines, ids
  // 100..147, cell k = ids 100 + 3k .. 102 + 3k); keyframe B (id 2), far away, sees 30 lines in
  // one cell (ids 200..229). Every line is a candidate; within a cell of A the first id is the
  // riskiest, and B's lines are riskier than all of A's.
  void SetUp() override {
    map_.cameras[0] = Pinhole();
    slam::ServerKeyframe a, b;
    a.id = 1;
    b.id = 2;
    a.camera_id = b.camera_id = 0;
    const Eigen::Vector3d centre_b(1000, 0, 0);
    b.cam_from_world.translation = -centre_b;
    slam::Id id = 100;
    for (int cell = 0; cell < 16; ++cell) {
      for (int k = 0; k < 3; ++k, ++id) {
        const double u = 160.0 * (cell % 4) + 40.0 + 30.0 * k, v = 120.0 * (cell / 4) + 60.0;
        AddLine(id, PointAt(u, v, Eigen::Vector3d::Zero()), &a);
        priority_[id] = 0.5 - 0.01 * k - 0.001 * cell;
      }
    }
    for (id = 200; id < 230; ++id) {
      AddLine(id, PointAt(330 + (id - 200), 250, centre_b), &b);
      priority_[id] = 0.9;
    }
    map_.server_keyframes[1] = a;
    map_.server_keyframes[2] = b;
  }
  void AddLine(slam::Id id, const Eigen::Vector3d& point, slam::ServerKeyframe* kf) {
    slam::LineLandmark l;
    l.id = id;
    const Eigen::Vector3d d = Eigen::Vector3d(1, 2, 3).normalized();
    l.line = slam::Line3d(point - d.dot(point) * d, d);
    l.server_keyframe_ids = {kf->id};
    map_.lines[id] = l;
    kf->line_ids.push_back(id);
    hidden_[id] = point;
  }
  slam::Map map_;
  std::map<slam::Id, double> priority_;
  std::map<slam::Id, Eigen::Vector3d> hidden_;
};

TEST_F(CoverageMitigationTest, GuardKeepsEveryKeyframeCoveredAndDropsTheRiskiestFirst) {
  CoverageDropOptions options;  // floor 24 lines, 4 x 4 grid: 2 lines per cell
  options.max_lines = 100;
  options.break_coverage_when_short = false;
  CoverageDropReport report;
  const slam::Map out = DropWithKeyframeCoverage(map_, priority_, hidden_, options, &report);
  // A: each cell keeps min(3, 2) = 2 lines, so 1 of 3 goes per cell: 16, and 32 >= 24 stay.
  // B: one cell of 30 lines keeps 2 by the cell floor but 24 by the keyframe floor: 6 go.
  EXPECT_EQ(report.num_candidates, 78);
  EXPECT_EQ(report.num_dropped, 22);
  EXPECT_EQ(report.num_protected, 56);
  EXPECT_EQ(out.server_keyframes.at(1).line_ids.size(), 32u);
  EXPECT_EQ(out.server_keyframes.at(2).line_ids.size(), 24u);
  for (int cell = 0; cell < 16; ++cell) {
    const slam::Id riskiest = 100 + 3 * cell;
    EXPECT_FALSE(out.lines.count(riskiest)) << "cell " << cell << ": its riskiest line stays";
    EXPECT_TRUE(out.lines.count(riskiest + 1) && out.lines.count(riskiest + 2)) << "cell " << cell;
  }
  for (slam::Id id = 200; id < 206; ++id) EXPECT_FALSE(out.lines.count(id)) << id;  // ties: by id
  for (slam::Id id = 206; id < 230; ++id) EXPECT_TRUE(out.lines.count(id)) << id;
  const KeyframeCoverageStats after = MeasureKeyframeCoverage(out, hidden_, options.coverage);
  EXPECT_EQ(after.keyframes_with_min_lines, 2);
  EXPECT_EQ(after.min_lines, 24);
  EXPECT_EQ(after.occupied_cells, 17);  // A's 16 cells and B's one

  // Without the guard the same budget empties B and A's riskiest cells: the guard is what
  // keeps the coverage.
  options.guard = false;
  const slam::Map plain = DropWithKeyframeCoverage(map_, priority_, hidden_, options, &report);
  EXPECT_EQ(report.num_dropped, 78);
  const KeyframeCoverageStats unguarded = MeasureKeyframeCoverage(plain, hidden_, options.coverage);
  EXPECT_EQ(unguarded.keyframes_with_min_lines, 0);
  EXPECT_EQ(unguarded.min_lines, 0);
}

TEST_F(CoverageMitigationTest, ProtectedLinesGoLastWhenTheBudgetNeedsThem) {
  CoverageDropOptions options;
  options.max_lines = 30;  // 22 unprotected candidates, then 8 protected ones by priority
  CoverageDropReport report;
  const slam::Map out = DropWithKeyframeCoverage(map_, priority_, hidden_, options, &report);
  EXPECT_EQ(report.num_dropped, 30);
  EXPECT_EQ(report.num_dropped_protected, 8);
  EXPECT_EQ(out.lines.size(), 78u - 30u);
  // The 8 protected ones are B's next riskiest (0.9 > A's): B keeps 16.
  EXPECT_EQ(out.server_keyframes.at(2).line_ids.size(), 16u);
  EXPECT_EQ(out.server_keyframes.at(1).line_ids.size(), 32u);
  // Priority <= 0 is never dropped, whatever the budget.
  std::map<slam::Id, double> only_a = priority_;
  for (slam::Id id = 200; id < 230; ++id) only_a[id] = 0.0;
  options.max_lines = 1000;
  DropWithKeyframeCoverage(map_, only_a, hidden_, options, &report);
  EXPECT_EQ(report.num_dropped, 48);
}

TEST_F(CoverageMitigationTest, AFirstTierGoesBeforeTheRestEvenWhenProtected) {
  // Budget 10: B's lines (0.9) are 6 unprotected + 24 protected, A's k = 0 lines (16) are
  // unprotected. One tier: B's 6, then 4 of A's. B's lines as a first tier (>= 0.8): B's 6,
  // then 4 protected ones of B before any of A's.
  CoverageDropOptions options;
  options.max_lines = 10;
  CoverageDropReport report;
  slam::Map out = DropWithKeyframeCoverage(map_, priority_, hidden_, options, &report);
  EXPECT_EQ(out.server_keyframes.at(2).line_ids.size(), 24u);
  EXPECT_EQ(out.server_keyframes.at(1).line_ids.size(), 44u);
  EXPECT_EQ(report.num_dropped_protected, 0);
  options.first_tier_priority = 0.8;
  out = DropWithKeyframeCoverage(map_, priority_, hidden_, options, &report);
  EXPECT_EQ(out.server_keyframes.at(2).line_ids.size(), 20u);
  EXPECT_EQ(out.server_keyframes.at(1).line_ids.size(), 48u);
  EXPECT_EQ(report.num_dropped_protected, 4);
}

TEST_F(CoverageMitigationTest, DirectionCapKeepsCellsProportional) {
  // Half of the lines (A's) along one direction, half of B's along another: a budget of 20
  // with B's lines riskier would take all 20 from B's direction; capped against the reference
  // (78 lines, F = 20 / 78), B's cell may lose at most ceil(F * 30) = 8.
  for (slam::Id id = 200; id < 230; ++id) {
    slam::Line3d& line = map_.lines.at(id).line;
    const Eigen::Vector3d d = Eigen::Vector3d(0, 0, 1);
    line = slam::Line3d(hidden_[id] - d.dot(hidden_[id]) * d, d);
  }
  const slam::Map reference = map_;
  CoverageDropOptions options;
  options.guard = false;
  options.max_lines = 20;
  options.direction_reference = &reference;
  CoverageDropReport report;
  const slam::Map out = DropWithKeyframeCoverage(map_, priority_, hidden_, options, &report);
  EXPECT_EQ(out.server_keyframes.at(2).line_ids.size(), 30u - 8u);
  EXPECT_EQ(report.num_held_for_directions, 22);
  EXPECT_EQ(report.num_dropped, 20);  // the rest from A's direction
  ASSERT_NE(DirectionCell(Eigen::Vector3d(1, 2, 3).normalized(), 8),
            DirectionCell(Eigen::Vector3d(0, 0, 1), 8));
}

TEST(RecoveredFirstPriority, RecoveredLinesOfAFailingRuleGoFirstAndTheExcessIsCounted) {
  // 10 lines, hidden points on the x axis; the density attack's estimates are exact for lines
  // 0..5, 1 unit off for 6..9; scene scale 100, so the rule "density@1%=0.2" (tolerance 1)
  // counts 6 recovered of 10 hidden points: 2 allowed, excess 4.
  AuditReport report;
  ReferenceMatch match;
  match.scene_scale = 100.0;
  AttackOutcome density;
  density.result.name = "density";
  density.result.Resize(10);
  for (int i = 0; i < 10; ++i) {
    density.result.line_ids[i] = 10 + i;
    match.hidden_points.emplace_back(i, 0, 0);
    match.matched.push_back(1);
    density.result.has_estimate[i] = 1;
    density.result.estimates[i] = Eigen::Vector3d(i, i < 6 ? 0.0 : 2.0, 0);
    density.result.risk[i] = 0.1 * i;  // the unrecovered 6..9 are the riskiest by score
  }
  match.matched_by_id = 10;
  match.num_reference_points = 10;
  const std::vector<FailRule> rules = ParseFailRules("density@1%=0.2");
  density.recovery = EvaluateRecovery(density.result, match, {rules[0].tolerance});
  report.reference_match = match;
  report.attacks.push_back(density);
  int excess = -1;
  const auto priority = RecoveredFirstPriority(report, rules, &excess);
  EXPECT_EQ(excess, 4);
  for (int i = 0; i < 10; ++i) {
    EXPECT_DOUBLE_EQ(priority.at(10 + i), 0.1 * i + (i < 6 ? kRecoveredPriority : 0.0)) << i;
  }
  // A rule that holds marks nothing: the plain risk.
  const auto holds = RecoveredFirstPriority(report, ParseFailRules("density@1%=0.7"), &excess);
  EXPECT_EQ(excess, 0);
  EXPECT_DOUBLE_EQ(holds.at(10), 0.0);
  EXPECT_EQ(HiddenPointsOf(report).size(), 10u);
  EXPECT_TRUE(HiddenPointsOf(report).at(13) == Eigen::Vector3d(3, 0, 0));
}

}  // namespace
}  // namespace lcv::privacy
