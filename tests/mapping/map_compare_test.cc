#include "mapping/map_compare.h"

#include <cmath>
#include <iterator>

#include <gtest/gtest.h>

#include "mapping/line_cloud.h"
#include "mapping/synthetic_map.h"
#include "slam/geometry/so3.h"

namespace lcv::mapping {
namespace {

slam::Map PointMap() {
  SyntheticMapOptions o;
  o.num_points = 300;
  o.num_keyframes = 10;
  o.seed = 7;
  return MakeSyntheticPointMap(o);
}

// Every pose, point and line of `map` moved by world2_from_world1.
slam::Map Moved(const slam::Map& map, const slam::Sim3d& s) {
  slam::Map out = map;
  for (auto& [id, kf] : out.keyframes) kf.cam_from_world = slam::TransformPose(s, kf.cam_from_world);
  for (auto& [id, kf] : out.server_keyframes) {
    kf.cam_from_world = slam::TransformPose(s, kf.cam_from_world);
  }
  for (auto& [id, p] : out.points) p.position = s * p.position;
  for (auto& [id, l] : out.lines) {
    l.line = slam::Line3d(s * l.line.anchor, s.rotation * l.line.direction);
    if (l.restored_point) l.restored_point = s * *l.restored_point;
  }
  return out;
}

const StructureDifference* Find(const MapComparison& c, slam::Id id) {
  for (const StructureDifference& d : c.structure) {
    if (d.id == id) return &d;
  }
  return nullptr;
}

TEST(MapCompare, AMapAgainstItselfAndAgainstItsLineCloud) {
  const slam::Map points = PointMap();
  MapComparison c = CompareMaps(points, points, MapCompareOptions());
  ASSERT_FALSE(c.problem);
  EXPECT_EQ(c.poses.size(), 10u);
  EXPECT_EQ(c.structure.size(), 300u);
  EXPECT_LT(c.pose_position_m.max, 1e-12);
  EXPECT_EQ(c.structure_distance_m[static_cast<int>(StructurePair::kPointPoint)].max, 0.0);

  // The published lines pass through the points they hide; client keyframes became server
  // keyframes of the same ids.
  const slam::Map lines = ConvertToLineCloud(points, LineCloudOptions());
  c = CompareMaps(points, lines, MapCompareOptions());
  ASSERT_FALSE(c.problem);
  ASSERT_EQ(c.poses.size(), 10u);
  EXPECT_FALSE(c.poses[0].server_in_reference);
  EXPECT_TRUE(c.poses[0].server_in_map);
  EXPECT_LT(c.pose_position_m.max, 1e-9);
  const ErrorStatistics& point_line =
      c.structure_distance_m[static_cast<int>(StructurePair::kPointLine)];
  EXPECT_EQ(point_line.count, 300);
  EXPECT_LT(point_line.max, 1e-9);
  EXPECT_EQ(c.structure_only_in_reference, 0);
  EXPECT_EQ(c.structure_only_in_map, 0);
}

TEST(MapCompare, AlignmentUndoesASimilarityAndLeavesWhatWasMoved) {
  const slam::Map reference = ConvertToLineCloud(PointMap(), LineCloudOptions());
  slam::Map changed = reference;
  // Planted changes: a server keyframe 0.5 m away, a line 0.3 m aside and one turned 10 degrees
  // about its anchor.
  auto kf = std::next(changed.server_keyframes.begin(), 4);
  const slam::Id moved_keyframe = kf->first;
  kf->second.cam_from_world = slam::TransformPose(
      slam::Sim3d(1.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.3, 0.0, 0.4)),
      kf->second.cam_from_world);
  auto shifted = std::next(changed.lines.begin(), 10);
  const Eigen::Vector3d aside = shifted->second.line.direction.unitOrthogonal() * 0.3;
  shifted->second.line.anchor += aside;
  auto turned = std::next(changed.lines.begin(), 20);
  const Eigen::Vector3d axis = turned->second.line.direction.unitOrthogonal();
  turned->second.line.direction =
      slam::ExpSO3(axis * (10.0 * M_PI / 180.0)) * turned->second.line.direction;
  // ... and the whole map in another frame and scale.
  const slam::Sim3d elsewhere(2.5, slam::ExpSO3(Eigen::Vector3d(0.3, -0.2, 1.0)),
                              Eigen::Vector3d(4, -1, 7));
  const slam::Map map = Moved(changed, elsewhere);

  MapCompareOptions options;
  options.align = true;
  const MapComparison c = CompareMaps(reference, map, options);
  ASSERT_FALSE(c.problem) << *c.problem;
  EXPECT_TRUE(c.aligned);
  EXPECT_NEAR(c.reference_from_map.scale, 1.0 / 2.5, 0.01);
  for (const PoseDifference& d : c.poses) {
    if (d.id == moved_keyframe) {
      EXPECT_NEAR(d.position_m, 0.5, 0.1);  // the alignment takes a little of it
    } else {
      EXPECT_LT(d.position_m, 0.1) << d.id;
    }
  }
  const StructureDifference* aside_line = Find(c, shifted->first);
  const StructureDifference* turned_line = Find(c, turned->first);
  ASSERT_NE(aside_line, nullptr);
  ASSERT_NE(turned_line, nullptr);
  EXPECT_EQ(aside_line->pair, StructurePair::kLineLine);
  EXPECT_NEAR(aside_line->distance_m, 0.3, 0.05);
  EXPECT_LT(aside_line->angle_deg, 1.0);
  EXPECT_NEAR(turned_line->angle_deg, 10.0, 1.0);
  EXPECT_EQ(c.line_angle_deg.count, 300);
  EXPECT_LT(c.line_angle_deg.median, 0.5);

  // Without alignment the frames differ: everything is far off.
  const MapComparison raw = CompareMaps(reference, map, MapCompareOptions());
  EXPECT_FALSE(raw.aligned);
  EXPECT_GT(raw.pose_position_m.median, 1.0);
}

TEST(MapCompare, CountsWhatOnlyOneMapHasAndComparesRestoredPoints) {
  const slam::Map points = PointMap();
  slam::Map lines = ConvertToLineCloud(points, LineCloudOptions());
  // The map lost three lines and a server keyframe, and gained a line of its own.
  for (int k = 0; k < 3; ++k) lines.lines.erase(std::prev(lines.lines.end()));
  const slam::Id dropped_keyframe = lines.server_keyframes.begin()->first;
  lines.server_keyframes.erase(dropped_keyframe);
  for (auto& [id, l] : lines.lines) {
    auto& ids = l.server_keyframe_ids;
    ids.erase(std::remove(ids.begin(), ids.end(), dropped_keyframe), ids.end());
  }
  slam::LineLandmark extra;
  extra.id = points.NextFreeId();  // in neither map
  lines.lines[extra.id] = extra;
  // A client restored a point 0.2 m from the hidden point of one line.
  slam::LineLandmark& restored_line = lines.lines.begin()->second;
  const Eigen::Vector3d hidden = points.points.at(restored_line.id).position;
  restored_line.restored_point = hidden + 0.2 * restored_line.line.direction;

  const MapComparison c = CompareMaps(points, lines, MapCompareOptions());
  ASSERT_FALSE(c.problem);
  EXPECT_EQ(c.poses_only_in_reference, 1);
  EXPECT_EQ(c.poses_only_in_map, 0);
  EXPECT_EQ(c.structure_only_in_reference, 3);
  EXPECT_EQ(c.structure_only_in_map, 1);
  EXPECT_EQ(c.structure.size(), 297u);
  ASSERT_EQ(c.restored.size(), 1u);
  EXPECT_EQ(c.restored[0].id, restored_line.id);
  EXPECT_NEAR(c.restored[0].distance_m, 0.2, 1e-9);
}

TEST(MapCompare, RefusesAnAlignmentWithoutCommonKeyframes) {
  const slam::Map reference = PointMap();
  slam::Map map = reference;
  map.keyframes.clear();
  MapCompareOptions options;
  options.align = true;
  const MapComparison c = CompareMaps(reference, map, options);
  ASSERT_TRUE(c.problem);
  EXPECT_NE(c.problem->find("0 keyframes in common"), std::string::npos) << *c.problem;
  // Unaligned it compares the points.
  EXPECT_FALSE(CompareMaps(reference, map, MapCompareOptions()).problem);
}

}  // namespace
}  // namespace lcv::mapping
