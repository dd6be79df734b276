#include "mapping/map_compare.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "slam/geometry/so3.h"
#include "slam/solve/umeyama.h"

namespace lcv::mapping {
namespace {

// A camera pose of either kind.
struct PoseEntity {
  slam::Rigid3d cam_from_world;
  bool server = false;
};

std::map<slam::Id, PoseEntity> Poses(const slam::Map& map) {
  std::map<slam::Id, PoseEntity> poses;
  for (const auto& [id, kf] : map.keyframes) poses[id] = {kf.cam_from_world, false};
  for (const auto& [id, kf] : map.server_keyframes) poses[id] = {kf.cam_from_world, true};
  return poses;
}

double Degrees(double radians) { return radians * 180.0 / M_PI; }

}  // namespace

const char* StructurePairName(StructurePair pair) {
  switch (pair) {
    case StructurePair::kPointPoint: return "point-point";
    case StructurePair::kPointLine: return "point-line";
    case StructurePair::kLinePoint: return "line-point";
    case StructurePair::kLineLine: return "line-line";
  }
  return "?";
}

MapComparison CompareMaps(const slam::Map& reference, const slam::Map& map,
                          const MapCompareOptions& options) {
  MapComparison out;
  const std::map<slam::Id, PoseEntity> reference_poses = Poses(reference);
  const std::map<slam::Id, PoseEntity> map_poses = Poses(map);

  struct CommonPose {
    slam::Id id;
    const PoseEntity* reference;
    const PoseEntity* map;
  };
  std::vector<CommonPose> common;
  std::vector<slam::Rigid3d> common_reference, common_map;
  for (const auto& [id, pose] : map_poses) {
    const auto it = reference_poses.find(id);
    if (it == reference_poses.end()) {
      ++out.poses_only_in_map;
      continue;
    }
    common.push_back({id, &it->second, &pose});
    common_reference.push_back(it->second.cam_from_world);
    common_map.push_back(pose.cam_from_world);
  }
  out.poses_only_in_reference = static_cast<int>(reference_poses.size() - common.size());

  if (options.align) {
    if (!slam::AlignMapDatum(common_map, common_reference, &out.reference_from_map)) {
      out.problem = "cannot align: " + std::to_string(common_map.size()) +
                    " keyframes in common, at least 2 with distinct centres needed";
      return out;
    }
    out.aligned = true;
  }
  const slam::Sim3d& s = out.reference_from_map;
  auto move_point = [&](const Eigen::Vector3d& x) { return s * x; };
  auto move_line = [&](const slam::Line3d& l) {
    return slam::Line3d(s * l.anchor, s.rotation * l.direction);
  };

  std::vector<double> positions, rotations;
  for (const CommonPose& c : common) {
    const slam::Rigid3d moved = slam::TransformPose(s, c.map->cam_from_world);
    const slam::Rigid3d& reference_pose = c.reference->cam_from_world;
    PoseDifference d;
    d.id = c.id;
    d.server_in_reference = c.reference->server;
    d.server_in_map = c.map->server;
    d.position_m = (moved.Center() - reference_pose.Center()).norm();
    d.rotation_deg = Degrees(slam::AngularDistance(moved.rotation, reference_pose.rotation));
    positions.push_back(d.position_m);
    rotations.push_back(d.rotation_deg);
    out.poses.push_back(d);
  }
  out.pose_position_m = ComputeErrorStatistics(positions);
  out.pose_rotation_deg = ComputeErrorStatistics(rotations);

  std::vector<double> distances[4], angles, restored;
  auto add = [&](slam::Id id, StructurePair pair, double distance, double angle) {
    out.structure.push_back({id, pair, distance, angle});
    distances[static_cast<int>(pair)].push_back(distance);
  };
  for (const auto& [id, point] : map.points) {
    const Eigen::Vector3d x = move_point(point.position);
    if (const auto r = reference.points.find(id); r != reference.points.end()) {
      add(id, StructurePair::kPointPoint, (x - r->second.position).norm(), 0.0);
    } else if (const auto l = reference.lines.find(id); l != reference.lines.end()) {
      add(id, StructurePair::kLinePoint, l->second.line.Distance(x), 0.0);
    } else {
      ++out.structure_only_in_map;
    }
  }
  for (const auto& [id, line_landmark] : map.lines) {
    const slam::Line3d line = move_line(line_landmark.line);
    std::optional<Eigen::Vector3d> hidden;  // what the map's X' is compared with
    if (const auto r = reference.points.find(id); r != reference.points.end()) {
      add(id, StructurePair::kPointLine, line.Distance(r->second.position), 0.0);
      hidden = r->second.position;
    } else if (const auto l = reference.lines.find(id); l != reference.lines.end()) {
      const double cosine = std::min(1.0, std::abs(line.direction.dot(l->second.line.direction)));
      const double angle = Degrees(std::acos(cosine));
      add(id, StructurePair::kLineLine, line.Distance(l->second.line.anchor), angle);
      angles.push_back(angle);
      hidden = l->second.restored_point;
    } else {
      ++out.structure_only_in_map;
    }
    if (line_landmark.restored_point && hidden) {
      const double d = (move_point(*line_landmark.restored_point) - *hidden).norm();
      out.restored.push_back({id, d});
      restored.push_back(d);
    }
  }
  std::sort(out.structure.begin(), out.structure.end(),
            [](const StructureDifference& a, const StructureDifference& b) { return a.id < b.id; });
  out.structure_only_in_reference =
      static_cast<int>(reference.points.size() + reference.lines.size() - out.structure.size());
  for (int k = 0; k < 4; ++k) out.structure_distance_m[k] = ComputeErrorStatistics(distances[k]);
  out.line_angle_deg = ComputeErrorStatistics(angles);
  out.restored_distance_m = ComputeErrorStatistics(restored);
  return out;
}

}  // namespace lcv::mapping
