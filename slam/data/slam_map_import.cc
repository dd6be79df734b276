#include "slam/data/slam_map_import.h"

#include <algorithm>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace lcv::slam {
namespace {

std::string Describe(const CameraParams& params) {
  std::ostringstream out;
  out << CameraModelName(params.model) << " " << params.cols << "x" << params.rows;
  return out.str();
}

// The checks that make a keyframe usable by the engine (see the header's failure list).
void CheckKeyframe(const Map& map, const Keyframe& keyframe, const Camera& camera) {
  const auto camera_it = map.cameras.find(keyframe.camera_id);
  if (camera_it == map.cameras.end()) {
    throw std::invalid_argument("keyframe " + std::to_string(keyframe.id) + ": camera " +
                                std::to_string(keyframe.camera_id) + " is not in the map");
  }
  const CameraParams& params = camera_it->second;
  if (params.model != camera.model() || params.cols != camera.cols() ||
      params.rows != camera.rows()) {
    throw std::invalid_argument("keyframe " + std::to_string(keyframe.id) + ": map camera " +
                                std::to_string(keyframe.camera_id) + " is " + Describe(params) +
                                ", the tracking camera is " + Describe(camera.params()));
  }
  if (keyframe.descriptors.size() != keyframe.keypoints.size()) {
    throw std::invalid_argument("keyframe " + std::to_string(keyframe.id) + " has " +
                                std::to_string(keyframe.descriptors.size()) +
                                " descriptors for " + std::to_string(keyframe.keypoints.size()) +
                                " keypoints (maps without descriptors cannot be tracked in)");
  }
}

void ImportKeyframe(const Keyframe& keyframe, const Camera& camera,
                    const ScaleLevels& scale_levels, int grid_cell_size_px,
                    std::vector<Eigen::Vector2d>* pixels, std::vector<unsigned char>* valid,
                    SlamMap* slam_map) {
  SlamKeyframe& kf = slam_map->AddKeyframeWithId(keyframe.id);
  kf.timestamp = keyframe.timestamp;
  kf.loaded = true;
  kf.camera = &camera;
  kf.scale_levels = scale_levels;
  kf.cam_from_world = keyframe.cam_from_world;
  kf.keypoints = keyframe.keypoints;
  kf.descriptors = keyframe.descriptors;
  const int n = static_cast<int>(kf.keypoints.size());
  // Bearings and grid exactly as PrepareFrame computes them for a tracked frame.
  pixels->resize(n);
  valid->resize(n);
  for (int i = 0; i < n; ++i) (*pixels)[i] = Eigen::Vector2d(kf.keypoints[i].x, kf.keypoints[i].y);
  std::vector<Eigen::Vector3d>& bearings = kf.bearings.overwrite();
  bearings.resize(n);
  if (n > 0) camera.UnprojectBatch(pixels->data(), n, bearings.data(), valid->data());
  for (int i = 0; i < n; ++i) {
    if (!(*valid)[i]) bearings[i].setZero();
  }
  kf.grid.Build(kf.keypoints, camera.cols(), camera.rows(), grid_cell_size_px);
  kf.landmark_ids.assign(n, kInvalidId);
}

void ImportPoint(const PointLandmark& point, SlamMap* slam_map) {
  if (slam_map->FindKeyframe(point.id) != nullptr) {
    throw std::invalid_argument("point " + std::to_string(point.id) +
                                ": id already used by a keyframe");
  }
  // Every observation must name an existing keypoint that no other point holds yet.
  for (const Observation& o : point.observations) {
    const SlamKeyframe* kf = slam_map->FindKeyframe(o.keyframe_id);
    const std::string where = "point " + std::to_string(point.id) + ": observation of keyframe " +
                              std::to_string(o.keyframe_id) + " keypoint " +
                              std::to_string(o.keypoint_index);
    if (kf == nullptr) throw std::invalid_argument(where + ": no such keyframe");
    if (o.keypoint_index >= kf->keypoints.size()) {
      throw std::invalid_argument(where + ": no such keypoint");
    }
    const Id holder = kf->landmark_ids[o.keypoint_index];
    if (holder != kInvalidId && holder != point.id) {
      throw std::invalid_argument(where + ": keypoint already observes point " +
                                  std::to_string(holder));
    }
  }
  // Local mapping links a new point to the keyframe that created it first, and that keyframe is
  // its reference until culled (then the first remaining observation): the first observation of
  // a saved point is its reference keyframe.
  const Id reference = point.observations.front().keyframe_id;
  SlamLandmark& landmark = slam_map->AddLandmarkWithId(point.id, point.position, reference);
  // File order is kept: the representative descriptor's tie-breaking depends on it.
  // AddObservation drops a second observation by the same keyframe.
  for (const Observation& o : point.observations) {
    slam_map->AddObservation(point.id, o.keyframe_id, static_cast<int>(o.keypoint_index));
  }
  slam_map->UpdateLandmarkGeometry(point.id);
  if (point.descriptor) landmark.descriptor = *point.descriptor;
}

// Lines, server keyframes (with their cameras) and the restored points X' of a line cloud. A map
// with client keyframes and lines is in the line cloud's frame (it was saved so): its segment is
// registered.
void ImportLineCloud(const Map& map, SlamMap* slam_map) {
  if (map.lines.empty()) return;
  for (const auto& [id, server_kf] : map.server_keyframes) {
    if (slam_map->FindKeyframe(id) != nullptr || slam_map->FindLandmark(id) != nullptr) {
      throw std::invalid_argument("server keyframe " + std::to_string(id) +
                                  ": id already used by a keyframe or point");
    }
    auto camera = map.cameras.find(server_kf.camera_id);
    if (camera == map.cameras.end()) {
      throw std::invalid_argument("server keyframe " + std::to_string(id) + ": camera " +
                                  std::to_string(server_kf.camera_id) + " missing");
    }
    slam_map->AddServerCamera(server_kf.camera_id, camera->second);
    SlamServerKeyframe& kf = slam_map->AddServerKeyframeWithId(id);
    kf.camera_id = server_kf.camera_id;
    kf.timestamp = server_kf.timestamp;
    kf.cam_from_world = server_kf.cam_from_world;
    kf.published_cam_from_world = server_kf.cam_from_world;
    kf.line_ids = server_kf.line_ids;
  }
  for (const auto& [id, line] : map.lines) {
    if (slam_map->FindKeyframe(id) != nullptr || slam_map->FindLandmark(id) != nullptr ||
        slam_map->FindServerKeyframe(id) != nullptr) {
      throw std::invalid_argument("line " + std::to_string(id) + ": id already in use");
    }
    SlamLine& out = slam_map->AddLineWithId(id);
    out.line = line.line;
    out.published_line = line.line;
    out.reference_line = line.line;
    out.information = line.information;
    out.sqrt_information = SqrtInformation(line.information);
    out.descriptor = line.descriptor;
    out.server_keyframe_ids = line.server_keyframe_ids;
  }
  // X' with their observations become landmarks with fresh ids (the file keeps them with their
  // line); without client keyframes there is nothing they could be observed in.
  for (const auto& [id, line] : map.lines) {
    if (!line.restored_point || line.observations.empty() || map.keyframes.empty()) continue;
    PointLandmark restored;
    restored.id = slam_map->NewId();
    restored.position = *line.restored_point;
    restored.observations = line.observations;
    ImportPoint(restored, slam_map);
    slam_map->RestoreOnLine(restored.id, id);
  }
  if (!map.keyframes.empty()) slam_map->SetRegisteredSegment(slam_map->active_segment());
}

}  // namespace

SlamMap ImportSlamMap(const Map& map, const Camera& camera, const ScaleLevels& scale_levels,
                      int grid_cell_size_px) {
  if (map.keyframes.empty() && map.lines.empty()) {  // a line cloud alone is usable
    throw std::invalid_argument("the map has neither client keyframes nor lines");
  }
  for (const auto& [id, keyframe] : map.keyframes) CheckKeyframe(map, keyframe, camera);

  SlamMap slam_map;
  slam_map.ReserveIdsBelow(map.NextFreeId());
  std::vector<Eigen::Vector2d> pixels;
  std::vector<unsigned char> valid;
  for (const auto& [id, keyframe] : map.keyframes) {
    ImportKeyframe(keyframe, camera, scale_levels, grid_cell_size_px, &pixels, &valid, &slam_map);
  }
  for (const auto& [id, point] : map.points) {
    if (!point.observations.empty()) ImportPoint(point, &slam_map);
  }
  // As UpdateCovisibility on each keyframe in id order, the order local mapping inserts them: a
  // keyframe's parent is chosen among the older ones, so the spanning tree is the one the engine
  // would have built.
  ImportLineCloud(map, &slam_map);
  slam_map.RebuildCovisibility();
  for (const auto& [a, b] : map.loop_edges) {
    if (slam_map.FindKeyframe(a) && slam_map.FindKeyframe(b)) slam_map.AddLoopEdge(a, b);
  }
  return slam_map;
}

}  // namespace lcv::slam
