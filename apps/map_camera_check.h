#pragma once
// `lcv slam --map-in`: the camera of a loaded map against the dataset's. Model and size must
// match (slam/data/slam_map_import.h refuses the map otherwise); the intrinsics may differ (a
// recalibration), and then the map's keypoints are re-read with the dataset's camera and
// --map-out stores the dataset's. That is what a user re-running on the same rig expects, but it
// must never happen silently: the warning names both values of every differing field.

#include <string>
#include <vector>

#include "slam/camera/camera.h"
#include "slam/data/map.h"

namespace lcv::apps {

// "fx 458.654 -> 500" for each of fx, fy, cx, cy and the distortion coefficients that differ
// between the map's camera and the dataset's; empty when they are equal or the model or size
// differ (that is an error reported elsewhere).
std::vector<std::string> IntrinsicsDifferences(const slam::CameraParams& map_camera,
                                               const slam::CameraParams& dataset_camera);

// One warning line per map camera whose intrinsics differ from the dataset's, e.g.
// "lcv slam: warning: a.lcmap: camera 0 differs from the dataset's camera (kitti00): fx 718.856
// -> 700 (map -> dataset); the map is used with the dataset's intrinsics". Empty when none.
std::string MapCameraWarnings(const slam::Map& map, const std::string& map_path,
                              const slam::CameraParams& dataset_camera,
                              const std::string& camera_source);

}  // namespace lcv::apps
