// ReleaseRestoredPointsOffTheirLines (slam/module/restored_point_release.h) on the ring scene's
// line cloud: X' planted on another point than their line's, with the line dragged after them,
// are released (kept as ordinary points, the line back where it was held); X' on their lines,
// and those seen only once, are not.
#include "slam/module/restored_point_release.h"

#include <cmath>
#include <set>
#include <vector>

#include <gtest/gtest.h>

#include "tests/slam/module/line_cloud_scene.h"
#include "tests/slam/module/loop_scene.h"

namespace lcv::slam {
namespace {

using testing::AddLineCloud;
using testing::LoopScene;
using testing::LoopSceneOptions;
using testing::MakeLoopScene;
using testing::RestoreOnLines;

constexpr double kMaxAngleRad = 1.5 * M_PI / 180.0;

struct Planted {
  std::set<Id> dragged;  // two or more observations, 1 m off their reference line
  Id seen_once = kInvalidId;
};

std::unique_ptr<LoopScene> MakeScene() {
  LoopSceneOptions options;
  options.num_keyframes = 16;
  std::unique_ptr<LoopScene> s = MakeLoopScene(options);
  const std::vector<Id> line_of_point = AddLineCloud({0, 2, 4, 6}, 3, s.get());
  EXPECT_GT(RestoreOnLines(line_of_point, 6, s.get()), 100);
  return s;
}

// Moves X' 1 m across their lines and drags the lines through them, as local BA does after a
// wrong association: the X' then lie on their (current) lines but far from the reference.
Planted Plant(LoopScene* s) {
  Planted planted;
  for (const auto& [id, landmark] : s->map.landmarks()) {
    if (!landmark.IsRestored()) continue;
    SlamLine* line = s->map.FindLine(landmark.line_id);
    const Eigen::Vector3d across = line->line.direction.unitOrthogonal();
    if (landmark.NumObservations() >= 2 && planted.dragged.size() < 10) {
      planted.dragged.insert(id);
    } else if (landmark.NumObservations() == 1 && planted.seen_once == kInvalidId) {
      planted.seen_once = id;
    } else {
      continue;
    }
    const Eigen::Vector3d moved = landmark.position_in_world + across;
    s->map.FindLandmark(id)->position_in_world = moved;
    // Dragged and turned a little, with Omega_L turned along as local BA's write-back does.
    line->MoveTo(Line3d(moved, (line->line.direction + 0.1 * across).normalized()));
  }
  return planted;
}

std::vector<Id> AllLandmarks(const SlamMap& map) {
  std::vector<Id> ids;
  for (const auto& [id, landmark] : map.landmarks()) ids.push_back(id);
  return ids;
}

TEST(RestoredPointRelease, ReleasesTheXPrimeThatDraggedTheirLinesAndKeepsThePoints) {
  const std::unique_ptr<LoopScene> s = MakeScene();
  const Planted planted = Plant(s.get());
  ASSERT_EQ(planted.dragged.size(), 10u);
  int restored_before = 0;
  for (const auto& [id, landmark] : s->map.landmarks()) restored_before += landmark.IsRestored();
  std::vector<int> observations_before;
  for (const Id id : planted.dragged) {
    observations_before.push_back(s->map.FindLandmark(id)->NumObservations());
  }

  const Eigen::Vector3d viewpoint = s->map.FindKeyframe(s->keyframe_ids[6])->Center();
  const int released =
      ReleaseRestoredPointsOffTheirLines(AllLandmarks(s->map), viewpoint, kMaxAngleRad, &s->map);

  EXPECT_EQ(released, 10);
  int restored_after = 0;
  for (const auto& [id, landmark] : s->map.landmarks()) restored_after += landmark.IsRestored();
  EXPECT_EQ(restored_after, restored_before - 10);
  int k = 0;
  for (const Id id : planted.dragged) {
    const SlamLandmark* landmark = s->map.FindLandmark(id);
    ASSERT_NE(landmark, nullptr) << "a released X' stays as an ordinary point";
    EXPECT_FALSE(landmark->IsRestored());
    EXPECT_EQ(landmark->NumObservations(), observations_before[k++]);
  }
  // Their lines are free again and back where they were held.
  for (const auto& [id, line] : s->map.lines()) {
    if (line.restored_landmark_id != kInvalidId) continue;
    EXPECT_LT((line.line.anchor - line.reference_line.anchor).norm(), 1e-12) << "line " << id;
    // Omega_L has no information along the line: turned back with it.
    EXPECT_LT((line.information * line.line.direction).norm(), 1e-9 * line.information.norm())
        << "line " << id;
  }
  // The planted X' seen once is not judged.
  if (planted.seen_once != kInvalidId) {
    EXPECT_TRUE(s->map.FindLandmark(planted.seen_once)->IsRestored());
  }
}

TEST(RestoredPointRelease, KeepsXPrimeOnTheirLinesAndDoesNothingWhenOff) {
  const std::unique_ptr<LoopScene> s = MakeScene();
  const Eigen::Vector3d viewpoint = s->map.FindKeyframe(s->keyframe_ids[6])->Center();
  // RestoreOnLines put every X' on its line: nothing to release.
  EXPECT_EQ(ReleaseRestoredPointsOffTheirLines(AllLandmarks(s->map), viewpoint, kMaxAngleRad,
                                               &s->map),
            0);
  Plant(s.get());
  EXPECT_EQ(ReleaseRestoredPointsOffTheirLines(AllLandmarks(s->map), viewpoint, 0.0, &s->map), 0);
  // A threshold above the planted offsets' angles keeps them too.
  EXPECT_EQ(ReleaseRestoredPointsOffTheirLines(AllLandmarks(s->map), viewpoint, M_PI / 2.0 - 1e-6,
                                               &s->map),
            0);
}

}  // namespace
}  // namespace lcv::slam
