#include "slam/optimize/map_bundle_adjustment.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "slam/geometry/line3.h"
#include "slam/geometry/so3.h"
#include "slam/optimize/residuals.h"
#include "tests/slam/optimize/optimize_test_util.h"

namespace lcv::slam {
namespace {

using testing::RandomPose;
using testing::TestCameraParams;

// A map as the curator sees it after a client uploaded its session into a line cloud: client
// keyframes with keypoints, points, lines (some with a restored point X' and its observations)
// and the server keyframes that published the lines.
Map MakeMap(std::mt19937* rng) {
  Map map;
  map.cameras[0] = TestCameraParams(CameraModel::kPerspective);
  const std::unique_ptr<Camera> camera = MakeCamera(map.cameras[0]);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.5);
  Id next_id = 0;
  std::vector<Id> keyframe_ids;
  for (int i = 0; i < 6; ++i) {
    Keyframe keyframe;
    keyframe.id = next_id++;
    keyframe.camera_id = 0;
    keyframe.cam_from_world =
        Rigid3d(ExpSO3(Eigen::Vector3d(0.0, 0.02 * i, 0.0)), Eigen::Vector3d(0.8 * i, 0.0, 0.0))
            .Inverse();
    keyframe_ids.push_back(keyframe.id);
    map.keyframes[keyframe.id] = keyframe;
  }
  std::vector<Id> server_ids;
  for (int s = 0; s < 5; ++s) {
    ServerKeyframe server;
    server.id = next_id++;
    server.camera_id = 0;
    server.cam_from_world = Rigid3d(ExpSO3(Eigen::Vector3d(0.03, -0.05 + 0.03 * s, 0.0)),
                                    Eigen::Vector3d(-0.5 + 1.2 * s, -0.6, 0.4))
                                .Inverse();
    server_ids.push_back(server.id);
    map.server_keyframes[server.id] = server;
  }
  auto observe = [&](const Eigen::Vector3d& x, std::vector<Observation>* observations) {
    for (const Id kf_id : keyframe_ids) {
      Keyframe& keyframe = map.keyframes[kf_id];
      const auto px = camera->Project(keyframe.cam_from_world * x);
      if (!px || !camera->InImage(*px, 5.0)) continue;
      Keypoint kp;
      kp.x = static_cast<float>(px->x() + noise(*rng));
      kp.y = static_cast<float>(px->y() + noise(*rng));
      kp.octave = static_cast<int>(3 * unit(*rng));
      observations->push_back({kf_id, static_cast<std::uint32_t>(keyframe.keypoints.size())});
      keyframe.keypoints.push_back(kp);
    }
  };
  for (int j = 0; j < 400; ++j) {
    const Eigen::Vector3d x(-3.0 + 10.0 * unit(*rng), -2.5 + 5.0 * unit(*rng),
                            6.0 + 8.0 * unit(*rng));
    if (j % 2 == 0) {
      PointLandmark point;
      point.id = next_id++;
      point.position = x;
      observe(x, &point.observations);
      map.points[point.id] = point;
    } else {
      LineLandmark line;
      line.id = next_id++;
      const Eigen::Vector3d d = UniformUnitVector(unit(*rng), unit(*rng));
      line.line = Line3d(x + (4.0 * unit(*rng) - 2.0) * d, d);
      line.information = LineInformation(d, 0.05 * 0.05 * Eigen::Matrix3d::Identity());
      line.restored_point = x;
      observe(x, &line.observations);
      for (const Id s : server_ids) {
        line.server_keyframe_ids.push_back(s);
        map.server_keyframes[s].line_ids.push_back(line.id);
      }
      map.lines[line.id] = line;
    }
  }
  return map;
}

TEST(GlobalBundleAdjustment, RecoversAPerturbedMapAndKeepsItsInvariants) {
  const unsigned seed = 51;
  std::mt19937 rng(seed);
  const Map truth = MakeMap(&rng);
  Map map = truth;
  std::normal_distribution<double> noise(0.0, 1.0);
  int rank = 0;
  for (auto& [id, keyframe] : map.keyframes) {
    // The two gauge keyframes stay at the truth.
    if (rank++ >= 2) {
      keyframe.cam_from_world = RandomPose(&rng, 0.005, 0.05) * keyframe.cam_from_world;
    }
  }
  for (auto& [id, server] : map.server_keyframes) {
    server.cam_from_world = RandomPose(&rng, 0.005, 0.05) * server.cam_from_world;
  }
  for (auto& [id, point] : map.points) {
    point.position += 0.1 * Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  }
  for (auto& [id, line] : map.lines) {
    const Line3d moved = RetractLine(
        line.line, Eigen::Vector4d(0.03 * noise(rng), 0.03 * noise(rng), 0.01 * noise(rng),
                                   0.01 * noise(rng)));
    line.line = moved;  // the information stays with the old direction: rotate it
    line.information = LineInformation(moved.direction, 0.05 * 0.05 * Eigen::Matrix3d::Identity());
    *line.restored_point += 0.1 * Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  }
  auto errors = [&](const Map& m) {
    double keyframe_error = 0.0, point_error = 0.0, line_error = 0.0;
    for (const auto& [id, keyframe] : m.keyframes) {
      keyframe_error = std::max(keyframe_error, (keyframe.cam_from_world.Center() -
                                                 truth.keyframes.at(id).cam_from_world.Center())
                                                    .norm());
    }
    for (const auto& [id, point] : m.points) {
      point_error += (point.position - truth.points.at(id).position).norm() / m.points.size();
    }
    for (const auto& [id, line] : m.lines) {
      line_error += line.line.Distance(*truth.lines.at(id).restored_point) / m.lines.size();
    }
    return std::array<double, 3>{keyframe_error, point_error, line_error};
  };
  const auto before = errors(map);
  // The virtual observations are taken from the map's current (perturbed) state, so the lines
  // are pulled back onto the client's observations only as far as the virtual observations let
  // them; the client part must be recovered fully.
  MapBundleOptions options;
  options.bundle.max_iterations = 20;
  const MapBundleReport report = GlobalBundleAdjustment(options, &map);
  ASSERT_TRUE(report.bundle.success) << report.bundle.message;
  EXPECT_EQ(report.num_keyframes, 6);
  EXPECT_EQ(report.num_server_keyframes, 5);
  EXPECT_EQ(report.num_virtual_observations, 5 * 200);
  EXPECT_EQ(report.num_skipped_observations, 0);
  const auto after = errors(map);
  RecordProperty("keyframe_error_m", std::to_string(before[0]) + " -> " + std::to_string(after[0]));
  RecordProperty("point_error_m", std::to_string(before[1]) + " -> " + std::to_string(after[1]));
  RecordProperty("line_error_m", std::to_string(before[2]) + " -> " + std::to_string(after[2]));
  EXPECT_LT(after[0], 0.3 * before[0]) << "keyframes " << before[0] << " -> " << after[0];
  EXPECT_LT(after[1], 0.3 * before[1]) << "points " << before[1] << " -> " << after[1];
  EXPECT_LT(after[2], before[2]) << "lines " << before[2] << " -> " << after[2];
  for (const auto& [id, line] : map.lines) {
    EXPECT_NEAR(line.line.direction.norm(), 1.0, 1e-12);
    EXPECT_LT((line.information * line.line.direction).norm(), 1e-6 * line.information.norm())
        << "line " << id;
    EXPECT_LT((line.information - line.information.transpose()).norm(), 1e-9);
  }
  // The gauge keyframe did not move.
  EXPECT_LT((map.keyframes.begin()->second.cam_from_world.translation -
             truth.keyframes.begin()->second.cam_from_world.translation)
                .norm(),
            1e-12);
}

TEST(GlobalBundleAdjustment, LineObservationsWithoutRestoredPointAreSkipped) {
  std::mt19937 rng(53);
  Map map = MakeMap(&rng);
  map.lines.begin()->second.restored_point.reset();
  const int expected = static_cast<int>(map.lines.begin()->second.observations.size());
  MapBundleOptions options;
  options.optimize_lines = false;
  options.optimize_server_keyframes = false;
  const MapBundleReport report = GlobalBundleAdjustment(options, &map);
  EXPECT_TRUE(report.bundle.success);
  EXPECT_EQ(report.num_skipped_observations, expected);
}

}  // namespace
}  // namespace lcv::slam
