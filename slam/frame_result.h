#pragma once
// What System::TrackImage returns per frame (slam/system.h), apart from the engine so that the
// tracking stage (slam/tracking.h) can produce it without including the engine.

#include <optional>

#include "slam/geometry/rigid3.h"
#include "slam/util/ids.h"

namespace lcv::slam {

enum class TrackingState { kInitializing, kTracking, kLost };
const char* TrackingStateName(TrackingState state);  // "initializing", "tracking", "lost"

struct FrameResult {
  Id frame_id = kInvalidId;
  double timestamp = 0.0;
  TrackingState state = TrackingState::kInitializing;
  std::optional<Rigid3d> cam_from_world;  // when tracked (or just initialized)
  int num_keypoints = 0;
  int num_matches = 0;  // inlier landmark matches after pose optimization
  // Of those, the e_pL terms: keypoints matched to an X' or to a line of the line cloud.
  int num_line_matches = 0;
  bool is_keyframe = false;  // handed to mapping as a keyframe (or initial keyframe)
  bool relocalized = false;  // pose found by relocalization (BoW + PnP) in this frame
  double extraction_ms = 0.0;  // feature extraction part of tracking_ms
  double tracking_ms = 0.0;    // whole TrackImage call minus mapping_ms
  // Deterministic mode: inline mapping time; threaded mode: time spent waiting for room in the
  // keyframe queue (mapping falling behind). Both include a (re)initialization's map building.
  double mapping_ms = 0.0;
};

}  // namespace lcv::slam
