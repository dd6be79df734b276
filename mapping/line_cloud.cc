#include "mapping/line_cloud.h"

#include <algorithm>
#include <random>
#include <set>

#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

using slam::Id;

// The anchor rule (see the header): the foot of the perpendicular from the map origin. It depends
// only on the line as a set of points, never on where on it the hidden point lies.
Eigen::Vector3d CanonicalAnchor(const Eigen::Vector3d& point_on_line,
                                const Eigen::Vector3d& direction) {
  return point_on_line - direction.dot(point_on_line) * direction;
}

}  // namespace

slam::Map ConvertToLineCloud(const slam::Map& point_map, const LineCloudOptions& options) {
  slam::Map out;
  out.cameras = point_map.cameras;
  out.description = point_map.description;
  out.server_keyframes = point_map.server_keyframes;

  // Lines already in the map: keep the line, drop what a client attached to it (X', x').
  for (const auto& [id, line] : point_map.lines) {
    slam::LineLandmark kept = line;
    kept.restored_point.reset();
    kept.observations.clear();
    kept.line.anchor = CanonicalAnchor(line.line.anchor, line.line.direction);
    for (const slam::Observation& obs : line.observations) {
      kept.server_keyframe_ids.push_back(obs.keyframe_id);
    }
    out.lines.emplace(id, std::move(kept));
  }

  // Points -> lines. Directions come from the seeded RNG in id order and nothing else.
  std::mt19937_64 rng(options.seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (const auto& [id, point] : point_map.points) {
    LCV_CHECK(!out.lines.count(id)) << "point id " << id << " is also a line id";
    slam::LineLandmark line;
    line.id = id;
    const double u = uniform(rng);
    const double v = uniform(rng);
    line.line.direction = slam::UniformUnitVector(u, v).normalized();
    line.line.anchor = CanonicalAnchor(point.position, line.line.direction);
    line.information = slam::LineInformation(line.line.direction, point.covariance);
    line.descriptor = point.descriptor;
    for (const slam::Observation& obs : point.observations) {
      line.server_keyframe_ids.push_back(obs.keyframe_id);
    }
    out.lines.emplace(id, std::move(line));
  }

  // Client keyframes -> server keyframes: pose and timestamp only.
  for (const auto& [id, kf] : point_map.keyframes) {
    LCV_CHECK(!out.server_keyframes.count(id))
        << "keyframe id " << id << " is also a server keyframe id";
    slam::ServerKeyframe server;
    server.id = id;
    server.camera_id = kf.camera_id;
    server.timestamp = kf.timestamp;
    server.cam_from_world = kf.cam_from_world;
    out.server_keyframes.emplace(id, std::move(server));
  }

  // Visibility both ways, sorted and unique: the union of what lines and server keyframes list,
  // without ids that do not exist.
  std::set<std::pair<Id, Id>> seen;  // (server keyframe id, line id)
  for (const auto& [line_id, line] : out.lines) {
    for (Id kf : line.server_keyframe_ids) seen.emplace(kf, line_id);
  }
  for (const auto& [kf_id, kf] : out.server_keyframes) {
    for (Id line_id : kf.line_ids) seen.emplace(kf_id, line_id);
  }
  for (auto& [line_id, line] : out.lines) line.server_keyframe_ids.clear();
  for (auto& [kf_id, kf] : out.server_keyframes) kf.line_ids.clear();
  for (const auto& [kf_id, line_id] : seen) {
    const auto kf = out.server_keyframes.find(kf_id);
    const auto line = out.lines.find(line_id);
    if (kf == out.server_keyframes.end() || line == out.lines.end()) continue;
    kf->second.line_ids.push_back(line_id);  // ascending: the set is ordered by (kf, line)
    line->second.server_keyframe_ids.push_back(kf_id);
  }
  for (auto& [line_id, line] : out.lines) {
    std::sort(line.server_keyframe_ids.begin(), line.server_keyframe_ids.end());
  }
  return out;
}

}  // namespace lcv::mapping
