#pragma once
// Test fixtures of the privacy suites: line clouds with known hidden points, built here (not with
// mapping::ConvertToLineCloud) so that each planted leak is explicit and under the test's control.

#include <cstdint>
#include <random>

#include "mapping/synthetic_map.h"
#include "slam/data/map.h"
#include "slam/geometry/line3.h"

namespace lcv::privacy::testing {

// The publishing rule of mapping/line_cloud.h: uniform direction, anchor = closest point to the
// origin, information from the point's covariance (eq. 1, LineInformationRule::kPointCovariance,
// not the default), descriptor kept, client keyframes -> server keyframes.
inline slam::Map MakeLineCloud(const slam::Map& point_map, std::uint64_t seed) {
  slam::Map out;
  out.cameras = point_map.cameras;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (const auto& [id, p] : point_map.points) {
    slam::LineLandmark l;
    l.id = id;
    const double u = uniform(rng), v = uniform(rng);
    const Eigen::Vector3d d = slam::UniformUnitVector(u, v);
    l.line = slam::Line3d(p.position - d.dot(p.position) * d, d);
    l.information = slam::LineInformation(d, p.covariance);
    l.descriptor = p.descriptor;
    for (const auto& obs : p.observations) l.server_keyframe_ids.push_back(obs.keyframe_id);
    out.lines[id] = l;
  }
  for (const auto& [id, kf] : point_map.keyframes) {
    slam::ServerKeyframe s;
    s.id = id;
    s.camera_id = kf.camera_id;
    s.timestamp = kf.timestamp;
    s.cam_from_world = kf.cam_from_world;
    out.server_keyframes[id] = s;
  }
  for (const auto& [id, p] : point_map.points) {
    for (const auto& obs : p.observations) out.server_keyframes[obs.keyframe_id].line_ids.push_back(id);
  }
  return out;
}

// The synthetic street of mapping/synthetic_map.h, small enough for unit tests.
inline slam::Map MakeStreetPointMap(int num_points, std::uint64_t seed, int num_keyframes = 30) {
  mapping::SyntheticMapOptions options;
  options.num_points = num_points;
  options.num_keyframes = num_keyframes;
  options.seed = seed;
  return mapping::MakeSyntheticPointMap(options);
}

}  // namespace lcv::privacy::testing
