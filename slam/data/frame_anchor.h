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

#include "slam/data/frame.h"
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

// The pose a keyframe candidate should enter today's map with: nullopt when its reference
// keyframe still has the pose and scale it had when the frame was tracked
// (Frame::reference_cam_from_world, Frame::reference_scale; or when they were not recorded, or
// the reference is no longer known), else the frame's offset from the reference re-anchored as
// AnchoredFramePose does. Why: live, the writer maps a candidate after the changes it made
// since the snapshot tracking used; a registration into a line cloud (a Sim(3) of scale 7.5)
// between the two put a keyframe into the server's frame with its pose still in the client's,
// 31 m off (fisheye s2, --realtime), and the frame's trajectory pose with it.
std::optional<Rigid3d> ReanchoredKeyframePose(const SlamMap& map, const Frame& frame);

}  // namespace lcv::slam
