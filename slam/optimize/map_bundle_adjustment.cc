#include "slam/optimize/map_bundle_adjustment.h"

#include <cmath>
#include <map>
#include <memory>
#include <sstream>

#include "slam/util/error.h"

namespace lcv::slam {

std::string MapBundleOptions::Problem() const {
  const std::string bundle_problem = bundle.Problem();
  if (!bundle_problem.empty()) return "bundle: " + bundle_problem;
  if (!(pyramid_scale_factor >= 1.0)) return "pyramid_scale_factor must be >= 1";
  if (num_fixed_keyframes < 1) return "num_fixed_keyframes must be >= 1";
  return "";
}

MapBundleReport GlobalBundleAdjustment(const MapBundleOptions& options, Map* map) {
  const std::string options_problem = options.Problem();
  LCV_CHECK(options_problem.empty()) << options_problem;
  LCV_CHECK(map != nullptr);

  std::map<Id, std::unique_ptr<Camera>> cameras;
  for (const auto& [id, params] : map->cameras) cameras[id] = MakeCamera(params);

  BundleProblem problem;
  std::map<Id, int> keyframe_index, point_index, line_index, server_index;
  for (const auto& [id, keyframe] : map->keyframes) {
    BundleKeyframe k;
    k.id = id;
    k.cam_from_world = keyframe.cam_from_world;
    k.camera = cameras.at(keyframe.camera_id).get();
    // The smallest ids: std::map is ordered.
    k.fixed = static_cast<int>(problem.keyframes.size()) < options.num_fixed_keyframes;
    keyframe_index[id] = static_cast<int>(problem.keyframes.size());
    problem.keyframes.push_back(k);
  }
  for (const auto& [id, server] : map->server_keyframes) {
    BundleServerKeyframe s;
    s.id = id;
    s.cam_from_world = server.cam_from_world;
    s.fixed = !options.optimize_server_keyframes ||
              (problem.keyframes.empty() &&
               static_cast<int>(problem.server_keyframes.size()) < options.num_fixed_keyframes);
    server_index[id] = static_cast<int>(problem.server_keyframes.size());
    problem.server_keyframes.push_back(s);
  }
  auto information_of = [&](const Observation& o) {
    const Keyframe& keyframe = map->keyframes.at(o.keyframe_id);
    const int octave = keyframe.keypoints[o.keypoint_index].octave;
    return std::pow(options.pyramid_scale_factor, -2.0 * octave);
  };
  auto pixel_of = [&](const Observation& o) {
    const Keypoint& kp = map->keyframes.at(o.keyframe_id).keypoints[o.keypoint_index];
    return Eigen::Vector2d(kp.x, kp.y);
  };
  MapBundleReport report;
  for (const auto& [id, point] : map->points) {
    BundlePoint p;
    p.id = id;
    p.position = point.position;
    const int index = static_cast<int>(problem.points.size());
    point_index[id] = index;
    problem.points.push_back(p);
    for (const Observation& o : point.observations) {
      BundleObservation obs;
      obs.keyframe = keyframe_index.at(o.keyframe_id);
      obs.landmark = index;
      obs.observed_px = pixel_of(o);
      obs.information = information_of(o);
      problem.observations.push_back(obs);
    }
  }
  for (const auto& [id, line] : map->lines) {
    BundleLine l;
    l.id = id;
    l.line = line.line;
    l.information = line.information;
    l.fixed = !options.optimize_lines;
    if (line.restored_point) l.restored_point = *line.restored_point;
    const int index = static_cast<int>(problem.lines.size());
    line_index[id] = index;
    problem.lines.push_back(l);
    for (const Observation& o : line.observations) {
      if (!line.restored_point) {
        ++report.num_skipped_observations;
        continue;
      }
      BundleObservation obs;
      obs.keyframe = keyframe_index.at(o.keyframe_id);
      obs.landmark = index;
      obs.on_line = true;
      obs.observed_px = pixel_of(o);
      obs.information = information_of(o);
      problem.observations.push_back(obs);
    }
  }
  std::vector<std::pair<int, int>> pairs;
  for (const auto& [id, server] : map->server_keyframes) {
    for (const Id line_id : server.line_ids) {
      pairs.emplace_back(server_index.at(id), line_index.at(line_id));
    }
  }
  MakeVirtualObservations(pairs, &problem);

  report.num_keyframes = static_cast<int>(problem.keyframes.size());
  report.num_server_keyframes = static_cast<int>(problem.server_keyframes.size());
  report.num_points = static_cast<int>(problem.points.size());
  report.num_lines = static_cast<int>(problem.lines.size());
  report.num_observations = static_cast<int>(problem.observations.size());
  report.num_virtual_observations = static_cast<int>(problem.virtual_observations.size());
  report.bundle = SolveBundleAdjustment(options.bundle, &problem);
  if (!report.bundle.success) return report;

  for (const BundleKeyframe& k : problem.keyframes) {
    map->keyframes.at(k.id).cam_from_world = k.cam_from_world;
  }
  for (const BundleServerKeyframe& s : problem.server_keyframes) {
    map->server_keyframes.at(s.id).cam_from_world = s.cam_from_world;
  }
  for (const BundlePoint& p : problem.points) map->points.at(p.id).position = p.position;
  for (const BundleLine& l : problem.lines) {
    LineLandmark& line = map->lines.at(l.id);
    line.information = TurnLineInformation(line.information, line.line.direction,
                                           l.line.direction);
    line.line = l.line;
    if (line.restored_point) line.restored_point = l.restored_point;
  }
  return report;
}

}  // namespace lcv::slam
