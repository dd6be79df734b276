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

// The settings that default to the camera's: features.num_features (from the image size) and
// keyframe_policy.max_frames (about one keyframe per second of video) where they are 0, i.e.
// not set by the settings file. Set both to 0 before ReadSlamConfig.
void ApplyCameraDefaults(const slam::CameraParams& camera, slam::SystemOptions* options);

}  // namespace lcv::apps
