// Tracker: retroactive posing of the frames an initialization waited through (issue 15). Kept
// apart from tracking.cc: it runs once per initialization and only adds records.

#include "slam/tracking.h"

namespace lcv::slam {

void Tracker::BufferInitializationFrame(const Frame& frame) {
  // Every frame since initializing began, also those of attempts whose reference was replaced:
  // once a map exists they are posed backwards from its reference frame.
  initialization_frames_.push_back(frame);
  // The newest kMaxInitializationFrames only (6 s at 10 Hz, two reference lifetimes by
  // default; a frame is ~0.1-0.4 MB at 1000-4000 features).
  constexpr size_t kMaxInitializationFrames = 60;
  if (initialization_frames_.size() > kMaxInitializationFrames) {
    initialization_frames_.erase(initialization_frames_.begin());
  }
}

void Tracker::PoseInitializationFrames(const LocalMapSnapshot& snapshot) {
  initialization_frames_pending_ = false;
  std::vector<Frame> frames;
  frames.swap(initialization_frames_);
  // Right after initialization the snapshot is centred on the initialization's second keyframe
  // (the current frame, last record); the first keyframe (the reference) is the world origin
  // (LocalMapper::Initialize), so the second one's pose is the motion over the span.
  const SnapshotKeyframe* second = snapshot.FindKeyframe(snapshot.reference_keyframe_id);
  if (second == nullptr || records_.empty() || records_.back().frame_id == kInvalidId) return;
  const Rigid3d second_inverse = second->cam_from_world.Inverse();
  auto make_record = [&](Id frame_id, double timestamp, const Rigid3d& cam_from_world) {
    FrameRecord record;
    record.frame_id = frame_id;
    record.timestamp = timestamp;
    record.reference_keyframe_id = second->id;
    record.frame_from_reference = cam_from_world * second_inverse;
    record.reference_scale = second->scale;
    record.cam_from_world = cam_from_world;
    return record;
  };
  std::vector<FrameRecord> posed;
  // The reference frame is the first keyframe: FrameTrajectory takes that keyframe's pose (by
  // source frame id) while it lives, else this offset from the second one.
  posed.push_back(make_record(initialization_reference_id_, initialization_reference_timestamp_,
                              Rigid3d()));

  const double span = second->timestamp - initialization_reference_timestamp_;
  const auto motion = second->cam_from_world.Log();
  // Searches the map from a predicted pose: the wide local-map search (4x window, relaxed view
  // and scale gates) absorbs the prediction's error, motion-only BA rejects wrong matches, then
  // the ordinary search and the ordinary inlier bar decide, as for any tracked frame.
  auto pose_frame = [&](const Rigid3d& predicted, Frame* frame) {
    frame->ResetMatches();
    frame->cam_from_world = predicted;
    frame->has_pose = true;
    MatchLocalMap(snapshot, frame, /*wide=*/true);
    if (OptimizePose(snapshot, frame) < options_.tracking.min_recovered_inliers) return false;
    MatchLocalMap(snapshot, frame);
    if (OptimizePose(snapshot, frame) < options_.tracking.min_tracked_inliers) return false;
    frame->cam_from_world.rotation.normalize();
    return true;
  };
  // Between the two keyframes: constant motion over the span as the prediction.
  for (Frame& frame : frames) {
    if (frame.id <= initialization_reference_id_ || frame.timestamp >= second->timestamp) continue;
    const double alpha =
        span > 0.0 ? (frame.timestamp - initialization_reference_timestamp_) / span : 0.5;
    if (pose_frame(Rigid3d::Exp(alpha * motion), &frame)) {
      posed.push_back(make_record(frame.id, frame.timestamp, frame.cam_from_world));
    }
  }
  // Before the reference (attempts whose reference was replaced): backwards in time, each
  // predicted by the velocity of the two nearest later poses, until one fails.
  std::vector<FrameRecord> earlier;
  Rigid3d later_pose;  // the reference, then each frame posed
  double later_time = initialization_reference_timestamp_;
  Rigid3d velocity = second->cam_from_world;  // later-from-earlier over velocity_time
  double velocity_time = span;
  for (auto it = frames.rbegin(); it != frames.rend(); ++it) {
    Frame& frame = *it;
    if (frame.id >= initialization_reference_id_) continue;
    if (!(velocity_time > 0.0)) break;
    const double back = (later_time - frame.timestamp) / velocity_time;
    const Rigid3d predicted = Rigid3d::Exp(-back * velocity.Log()) * later_pose;
    if (!pose_frame(predicted, &frame)) break;
    velocity = later_pose * frame.cam_from_world.Inverse();
    velocity_time = later_time - frame.timestamp;
    later_pose = frame.cam_from_world;
    later_time = frame.timestamp;
    earlier.push_back(make_record(frame.id, frame.timestamp, frame.cam_from_world));
  }
  posed.insert(posed.begin(), earlier.rbegin(), earlier.rend());
  // Before the initialization's current frame, in frame order.
  records_.insert(records_.end() - 1, posed.begin(), posed.end());

  // After it: frames that arrived while the mapping thread built the map (threaded mode only;
  // inline the map exists before the next frame). Forwards, each predicted by the
  // initialization's motion from the last frame posed, after the current frame's record.
  Rigid3d earlier_pose = second->cam_from_world;
  double earlier_time = second->timestamp;
  for (Frame& frame : frames) {
    if (frame.timestamp <= second->timestamp || !(span > 0.0)) continue;
    const double ahead = (frame.timestamp - earlier_time) / span;
    if (!pose_frame(Rigid3d::Exp(ahead * motion) * earlier_pose, &frame)) continue;
    earlier_pose = frame.cam_from_world;
    earlier_time = frame.timestamp;
    records_.push_back(make_record(frame.id, frame.timestamp, frame.cam_from_world));
  }
}

}  // namespace lcv::slam
