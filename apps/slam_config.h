#pragma once
// The settings file of `lcv slam --config` (and of the benchmarks that take one): YAML (the
// project's subset, mapping/io/yaml_subset.h) or JSON, with sections named as stella_vslam's
// where one exists: Camera (ignored here: the dataset's camera or --camera is used), Feature,
// Initializer, Tracking, Mapping, KeyframeInserter, Relocalization, LoopClosing, System. Every
// key is range-checked; unknown sections and keys are errors (a typo must not be silently
// ignored). docs/slam.md lists the keys with their defaults.

#include <string>

#include "slam/system.h"

namespace lcv::apps {

// Overrides the fields of *options that the file sets. Throws lcv::InputError naming the file,
// the section, the key and the problem.
void ReadSlamConfig(const std::string& path, slam::SystemOptions* options);

// Default options with the settings that follow the camera unset: features.num_features,
// keyframe_policy.max_frames, keyframe_policy.max_travel_of_depth_in_line_cloud and
// line_cloud.line_search_backoff.misses. Start from
// these, apply ReadSlamConfig, then ApplyCameraDefaults.
slam::SystemOptions OptionsWithoutCameraDefaults();

// Fills the settings that OptionsWithoutCameraDefaults left unset and the settings file did not
// set: num_features from the image size, max_frames about one keyframe per second of video,
// max_travel_of_depth_in_line_cloud 0.1 for a fisheye camera, 0.15 for an equirectangular one and
// 0 (the common travel rule) for a perspective one; the line search's back-off (misses 2) for an
// equirectangular camera only.
void ApplyCameraDefaults(const slam::CameraParams& camera, slam::SystemOptions* options);

}  // namespace lcv::apps
