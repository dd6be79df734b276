// Tracker: results other threads hand back to the tracker (docs/slam.md "Threads"): an
// asynchronous relocalization, a refused keyframe, records of a map the writer dropped.

#include <algorithm>

#include "slam/tracking.h"

namespace lcv::slam {

bool Tracker::PauseKeyframesAfterRelocalization(const LocalMapSnapshot& snapshot,
                                                 const Rigid3d& cam_from_world) const {
  if (snapshot.map_num_keyframes <= options_.keyframe_policy.max_frames) return false;
  // A frame relocalized in the line cloud may be far from every keyframe of the map (its
  // reference is the nearest one): the map does not cover its place, it needs keyframes there.
  const SnapshotKeyframe* reference = snapshot.FindKeyframe(snapshot.reference_keyframe_id);
  if (reference == nullptr || !(snapshot.reference_median_distance > 0.0)) return true;
  const double travel = (cam_from_world.Center() - reference->cam_from_world.Center()).norm();
  return travel <= options_.keyframe_policy.max_travel_of_depth * snapshot.reference_median_distance;
}

bool Tracker::OnRelocalized(Frame frame, const LocalMapSnapshot& snapshot) {
  if (state_ != TrackingState::kLost) return false;
  const SnapshotKeyframe* reference = snapshot.FindKeyframe(frame.reference_keyframe_id);
  if (reference == nullptr || (has_last_frame_ && frame.id <= last_frame_.id)) return false;
  frame.cam_from_world.rotation.normalize();
  const Rigid3d frame_from_reference = frame.cam_from_world * reference->cam_from_world.Inverse();
  FrameRecord record;
  record.frame_id = frame.id;
  record.timestamp = frame.timestamp;
  record.reference_keyframe_id = reference->id;
  record.frame_from_reference = frame_from_reference;
  record.reference_scale = reference->scale;
  record.cam_from_world = frame.cam_from_world;
  records_.push_back(record);
  // As after an inline relocalization: no velocity across the loss, no keyframe for about a
  // second in a grown map (ORB-SLAM).
  velocity_.reset();
  consecutive_lost_ = 0;
  last_tracked_timestamp_ = frame.timestamp;
  tracked_in_loaded_map_ = tracked_in_loaded_map_ || map_loaded_;
  state_ = TrackingState::kTracking;
  frames_since_keyframe_ = PauseKeyframesAfterRelocalization(snapshot, frame.cam_from_world)
                               ? -options_.keyframe_policy.max_frames
                               : 0;
  // A frame relocalized in the line cloud has no matches for the motion model to follow.
  track_local_map_from_last_pose_ =
      std::none_of(frame.landmark_ids.begin(), frame.landmark_ids.end(),
                   [](Id id) { return id != kInvalidId; });
  last_frame_ = std::move(frame);
  has_last_frame_ = true;
  last_frame_two_view_without_map_ = false;
  consecutive_two_view_frames_ = 0;
  last_frame_from_reference_ = frame_from_reference;
  last_frame_reference_scale_ = record.reference_scale;
  return true;
}

void Tracker::OnKeyframeRefused() { frames_since_keyframe_ = frames_since_keyframe_before_candidate_; }

void Tracker::DropRecordsBefore(Id first_kept_frame_id) {
  records_.erase(std::remove_if(records_.begin(), records_.end(),
                                [&](const FrameRecord& r) { return r.frame_id < first_kept_frame_id; }),
                 records_.end());
}

}  // namespace lcv::slam
