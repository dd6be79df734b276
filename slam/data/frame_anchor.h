#pragma once
// Frames are not map objects: tracking records each one as a rigid offset from a keyframe (its
// reference) and its pose is rebuilt from that keyframe's pose whenever the map has changed
// (ORB-SLAM's mlRelativeFramePoses). Two map edits break a plain rigid offset:
// - the keyframe is erased (culling): the offset is chained through SlamMap::erased_keyframes()
//   to a living keyframe;
// - a Sim(3) correction (loop closing) rescales the map around the keyframe: the offset's
//   translation is in the units of the time it was recorded and is multiplied by
//   SlamKeyframe::scale now / scale then.

#include <optional>

#include "slam/data/slam_map.h"
#include "slam/geometry/rigid3.h"

namespace lcv::slam {

// frame_from_keyframe recorded when the keyframe's SlamKeyframe::scale was recorded_scale,
// expressed for a keyframe scale of current_scale.
Rigid3d RescaledOffset(const Rigid3d& frame_from_keyframe, double recorded_scale,
                       double current_scale);

// cam_from_world of a frame recorded as frame_from_reference against reference_keyframe_id
// (whose scale was reference_scale then), in today's map; nullopt when the reference (or the
// chain of keyframes that replaced it) is no longer known.
// anchor (optional): the living keyframe the pose was rebuilt from.
std::optional<Rigid3d> AnchoredFramePose(const SlamMap& map, Id reference_keyframe_id,
                                         const Rigid3d& frame_from_reference,
                                         double reference_scale, Id* anchor = nullptr);

}  // namespace lcv::slam
