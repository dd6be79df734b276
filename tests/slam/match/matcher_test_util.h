#pragma once
// A prepared Frame from synthetic observations (tests/slam/system/synthetic_features.h).
#include "slam/data/frame.h"
#include "tests/slam/system/synthetic_features.h"

namespace lcv::slam::testing {

inline Frame MakeFrame(const Camera& camera, const SyntheticFrame& s, const Rigid3d& pose, Id id) {
  Frame frame;
  frame.id = id;
  frame.camera = &camera;
  frame.keypoints = s.keypoints;
  frame.descriptors = s.descriptors;
  frame.cam_from_world = pose;
  frame.has_pose = true;
  PrepareFrame(&frame);
  return frame;
}

}  // namespace lcv::slam::testing
