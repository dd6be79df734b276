#include "slam/module/keyframe_policy.h"

namespace lcv::slam {

bool NeedNewKeyframe(const KeyframeDecisionInput& input, const KeyframePolicyOptions& options) {
  // A two-view pose is the one way to go on: its keyframe brings the points the map lacks.
  if (input.two_view) return true;
  // The keyframe would observe the X' and lines too: they count toward min_tracked (not toward
  // the ratios below, which judge the client's own map).
  if (input.num_tracked + input.num_line_cloud_tracked < options.min_tracked) return false;
  if (input.motion_model_failed) return true;
  const double max_travel = input.registered_in_line_cloud &&
                                    options.max_travel_of_depth_in_line_cloud > 0.0
                                ? options.max_travel_of_depth_in_line_cloud
                                : options.max_travel_of_depth;
  if (max_travel > 0.0 && input.travel_of_depth >= max_travel &&
      input.frames_since_last_keyframe >= options.travel_min_frames) {
    return true;
  }
  const bool due = input.frames_since_last_keyframe >= options.max_frames;
  const bool allowed =
      input.frames_since_last_keyframe >= options.min_frames && input.mapping_idle;
  const bool weak = input.num_tracked < options.weak_tracking ||
                    input.num_tracked < options.weak_ratio * input.reference_num_tracked;
  const bool few_of_reference =
      input.num_tracked < options.tracked_ratio * input.reference_num_tracked;
  const bool cloud_fading =
      input.registered_in_line_cloud && !input.sees_all_around &&
      options.line_cloud_fading_ratio > 0.0 &&
      input.reference_num_restored >= options.line_cloud_fading_min &&
      input.num_line_cloud_tracked < options.line_cloud_fading_ratio * input.reference_num_restored;
  if (!(few_of_reference || weak || cloud_fading)) return false;
  // Weak tracking inserts even while mapping is busy (the queue is bounded): without new
  // points the tracker would soon be lost.
  return due || allowed || weak;
}

}  // namespace lcv::slam
