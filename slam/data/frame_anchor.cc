#include "slam/data/frame_anchor.h"

namespace lcv::slam {

Rigid3d RescaledOffset(const Rigid3d& frame_from_keyframe, double recorded_scale,
                       double current_scale) {
  Rigid3d rescaled = frame_from_keyframe;
  if (recorded_scale > 0.0 && current_scale != recorded_scale) {
    rescaled.translation *= current_scale / recorded_scale;
  }
  return rescaled;
}

std::optional<Rigid3d> AnchoredFramePose(const SlamMap& map, Id reference_keyframe_id,
                                         const Rigid3d& frame_from_reference,
                                         double reference_scale, Id* anchor_id) {
  Id anchor = reference_keyframe_id;
  Rigid3d frame_from_anchor = frame_from_reference;
  double recorded_scale = reference_scale;
  // Culling erases one keyframe at a time, each re-anchored to a living one: the chain is
  // short, the guard only protects against a corrupted map.
  for (int guard = 0; guard < 1000 && map.FindKeyframe(anchor) == nullptr; ++guard) {
    auto erased = map.erased_keyframes().find(anchor);
    if (erased == map.erased_keyframes().end()) return std::nullopt;
    frame_from_anchor = RescaledOffset(frame_from_anchor, recorded_scale,
                                       erased->second.erased_scale) *
                        erased->second.erased_from_anchor;
    recorded_scale = erased->second.anchor_scale;
    anchor = erased->second.anchor_id;
  }
  const SlamKeyframe* keyframe = map.FindKeyframe(anchor);
  if (keyframe == nullptr) return std::nullopt;
  if (anchor_id != nullptr) *anchor_id = anchor;
  return RescaledOffset(frame_from_anchor, recorded_scale, keyframe->scale) *
         keyframe->cam_from_world;
}

std::optional<Rigid3d> ReanchoredKeyframePose(const SlamMap& map, const Frame& frame) {
  if (!(frame.reference_scale > 0.0) || frame.reference_keyframe_id == kInvalidId) {
    return std::nullopt;
  }
  const SlamKeyframe* reference = map.FindKeyframe(frame.reference_keyframe_id);
  // Exactly as tracked (always so inline: nothing runs between tracking and mapping).
  if (reference != nullptr && reference->scale == frame.reference_scale &&
      reference->cam_from_world.translation == frame.reference_cam_from_world.translation &&
      reference->cam_from_world.rotation.coeffs() ==
          frame.reference_cam_from_world.rotation.coeffs()) {
    return std::nullopt;
  }
  const Rigid3d frame_from_reference =
      frame.cam_from_world * frame.reference_cam_from_world.Inverse();
  return AnchoredFramePose(map, frame.reference_keyframe_id, frame_from_reference,
                           frame.reference_scale);
}

}  // namespace lcv::slam
