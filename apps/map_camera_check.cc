#include "apps/map_camera_check.h"

#include <sstream>

namespace lcv::apps {

std::vector<std::string> IntrinsicsDifferences(const slam::CameraParams& map_camera,
                                               const slam::CameraParams& dataset_camera) {
  std::vector<std::string> out;
  if (map_camera.model != dataset_camera.model || map_camera.cols != dataset_camera.cols ||
      map_camera.rows != dataset_camera.rows) {
    return out;
  }
  const auto compare = [&](const std::string& name, double in_map, double in_dataset) {
    if (in_map == in_dataset) return;
    std::ostringstream text;
    text.precision(17);
    text << name << " " << in_map << " -> " << in_dataset;
    out.push_back(text.str());
  };
  if (map_camera.model == slam::CameraModel::kEquirectangular) return out;  // no intrinsics
  compare("fx", map_camera.fx, dataset_camera.fx);
  compare("fy", map_camera.fy, dataset_camera.fy);
  compare("cx", map_camera.cx, dataset_camera.cx);
  compare("cy", map_camera.cy, dataset_camera.cy);
  for (int i = 0; i < 5; ++i) {
    compare("distortion[" + std::to_string(i) + "]", map_camera.distortion[i],
            dataset_camera.distortion[i]);
  }
  return out;
}

std::string MapCameraWarnings(const slam::Map& map, const std::string& map_path,
                              const slam::CameraParams& dataset_camera,
                              const std::string& camera_source) {
  std::string warnings;
  for (const auto& [id, camera] : map.cameras) {
    const std::vector<std::string> differences = IntrinsicsDifferences(camera, dataset_camera);
    if (differences.empty()) continue;
    std::string list;
    for (const std::string& d : differences) list += (list.empty() ? "" : ", ") + d;
    warnings += "lcv slam: warning: " + map_path + ": camera " + std::to_string(id) +
                " differs from the dataset's camera (" + camera_source + "): " + list +
                " (map -> dataset); the map is used with the dataset's intrinsics, and "
                "--map-out stores them\n";
  }
  return warnings;
}

}  // namespace lcv::apps
