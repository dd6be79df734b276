// Loading any map into the engine and exporting it again loses nothing (issue 11: points-only,
// lines-only and mixed maps). Property test over synthetic maps of several seeds.
#include <cstdint>

#include <gtest/gtest.h>

#include "mapping/line_cloud.h"
#include "mapping/synthetic_map.h"
#include "slam/data/map.h"
#include "slam/system.h"

namespace lcv::slam {
namespace {

Map SyntheticClientMap(std::uint64_t seed) {
  mapping::SyntheticMapOptions options;
  options.num_points = 300;
  options.num_keyframes = 8;
  options.seed = seed;
  return mapping::MakeSyntheticPointMap(options);
}

// A line cloud of another synthetic map, its ids moved past `first_free_id`.
Map ShiftedLineCloud(std::uint64_t seed, Id first_free_id) {
  mapping::LineCloudOptions line_options;
  line_options.seed = seed;
  const Map cloud = mapping::ConvertToLineCloud(SyntheticClientMap(seed + 100), line_options);
  Map out;
  out.cameras = cloud.cameras;
  auto shift = [&](Id id) { return id + first_free_id; };
  for (const auto& [id, line] : cloud.lines) {
    LineLandmark moved = line;
    moved.id = shift(id);
    for (Id& kf : moved.server_keyframe_ids) kf = shift(kf);
    out.lines[moved.id] = moved;
  }
  for (const auto& [id, kf] : cloud.server_keyframes) {
    ServerKeyframe moved = kf;
    moved.id = shift(id);
    for (Id& line : moved.line_ids) line = shift(line);
    out.server_keyframes[moved.id] = moved;
  }
  return out;
}

// The client map plus a line cloud in the same frame; some client points are X' of lines.
Map MixedMap(std::uint64_t seed) {
  Map map = SyntheticClientMap(seed);
  const Map cloud = ShiftedLineCloud(seed, map.NextFreeId());
  map.lines = cloud.lines;
  map.server_keyframes = cloud.server_keyframes;
  // Every 10th client point becomes the restored point of a line (moved onto it).
  int k = 0;
  auto line = map.lines.begin();
  for (auto it = map.points.begin(); it != map.points.end() && line != map.lines.end(); ++k) {
    if (k % 10 != 0) {
      ++it;
      continue;
    }
    line->second.restored_point = line->second.line.Project(it->second.position);
    line->second.observations = it->second.observations;
    it = map.points.erase(it);
    ++line;
  }
  return map;
}

void ExpectSameMap(const Map& expected, const Map& actual) {
  ASSERT_EQ(expected.keyframes.size(), actual.keyframes.size());
  for (const auto& [id, kf] : expected.keyframes) {
    const Keyframe& other = actual.keyframes.at(id);
    EXPECT_LT((kf.cam_from_world.translation - other.cam_from_world.translation).norm(), 1e-12);
    EXPECT_LT(kf.cam_from_world.rotation.angularDistance(other.cam_from_world.rotation), 1e-12);
    EXPECT_EQ(kf.keypoints.size(), other.keypoints.size());
    EXPECT_EQ(kf.descriptors, other.descriptors);
  }
  ASSERT_EQ(expected.points.size(), actual.points.size());
  for (const auto& [id, point] : expected.points) {
    const PointLandmark& other = actual.points.at(id);
    EXPECT_LT((point.position - other.position).norm(), 1e-12) << "point " << id;
    EXPECT_EQ(point.observations.size(), other.observations.size()) << "point " << id;
  }
  ASSERT_EQ(expected.lines.size(), actual.lines.size());
  for (const auto& [id, line] : expected.lines) {
    const LineLandmark& other = actual.lines.at(id);
    EXPECT_EQ(line.line.anchor, other.line.anchor) << "line " << id;
    EXPECT_EQ(line.line.direction, other.line.direction) << "line " << id;
    EXPECT_EQ(line.information, other.information) << "line " << id;
    EXPECT_EQ(line.descriptor, other.descriptor) << "line " << id;
    EXPECT_EQ(line.server_keyframe_ids, other.server_keyframe_ids) << "line " << id;
    ASSERT_EQ(line.restored_point.has_value(), other.restored_point.has_value()) << "line " << id;
    if (line.restored_point) {
      EXPECT_LT((*line.restored_point - *other.restored_point).norm(), 1e-12) << "line " << id;
      ASSERT_EQ(line.observations.size(), other.observations.size()) << "line " << id;
      for (size_t k = 0; k < line.observations.size(); ++k) {
        EXPECT_EQ(line.observations[k].keyframe_id, other.observations[k].keyframe_id);
        EXPECT_EQ(line.observations[k].keypoint_index, other.observations[k].keypoint_index);
      }
    }
  }
  ASSERT_EQ(expected.server_keyframes.size(), actual.server_keyframes.size());
  for (const auto& [id, kf] : expected.server_keyframes) {
    const ServerKeyframe& other = actual.server_keyframes.at(id);
    EXPECT_EQ(kf.line_ids, other.line_ids) << "server keyframe " << id;
    EXPECT_EQ(kf.cam_from_world.translation, other.cam_from_world.translation);
    EXPECT_EQ(kf.timestamp, other.timestamp);
    ASSERT_TRUE(actual.cameras.count(other.camera_id));
    EXPECT_EQ(actual.cameras.at(other.camera_id).model,
              expected.cameras.at(kf.camera_id).model);
    EXPECT_EQ(actual.cameras.at(other.camera_id).fx, expected.cameras.at(kf.camera_id).fx);
  }
  EXPECT_EQ(expected.loop_edges, actual.loop_edges);
}

Map RoundTrip(const Map& map) {
  SystemOptions options;
  options.deterministic = true;
  System system(map.cameras.begin()->second, options);
  system.LoadMap(map);
  system.Finish();
  return system.ExportMap();
}

TEST(MapRoundTrip, PointsOnlyMapLosesNothing) {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    SCOPED_TRACE(seed);
    const Map map = SyntheticClientMap(seed);
    ExpectSameMap(map, RoundTrip(map));
  }
}

TEST(MapRoundTrip, LineCloudLosesNothing) {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    SCOPED_TRACE(seed);
    const Map map = ShiftedLineCloud(seed, 1);
    ASSERT_FALSE(map.lines.empty());
    ExpectSameMap(map, RoundTrip(map));
  }
}

TEST(MapRoundTrip, MixedMapLosesNothing) {
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    SCOPED_TRACE(seed);
    const Map map = MixedMap(seed);
    int restored = 0;
    for (const auto& [id, line] : map.lines) restored += line.restored_point.has_value();
    ASSERT_GT(restored, 10);
    ExpectSameMap(map, RoundTrip(map));
  }
}

}  // namespace
}  // namespace lcv::slam
