#include "slam/tracking.h"

#include <algorithm>
#include <cmath>

#include "slam/data/frame_anchor.h"
#include "slam/match/epipolar_matcher.h"
#include "slam/util/thread_clock.h"

namespace lcv::slam {

Tracker::Tracker(const SystemOptions& options)
    : options_(options),
      initializer_(options.initializer),
      line_search_backoff_(options.line_cloud.line_search_backoff) {}

void Tracker::Reset(bool keep_records) {
  state_ = TrackingState::kInitializing;
  last_num_inliers_ = 0;
  initializer_.Reset();
  initialization_frames_.clear();
  initialization_frames_pending_ = false;
  has_last_frame_ = false;
  last_frame_two_view_without_map_ = false;
  consecutive_two_view_frames_ = 0;
  line_cloud_check_retries_left_ = 0;
  track_local_map_from_last_pose_ = false;
  velocity_.reset();
  frames_since_keyframe_ = 0;
  consecutive_lost_ = 0;
  if (!keep_records) records_.clear();
  awaiting_map_ = false;
  map_loaded_ = false;
  localization_only_ = false;
  may_start_own_map_ = false;
  tracked_in_loaded_map_ = false;
  loaded_map_first_timestamp_.reset();
  line_search_backoff_.Clear();
}

void Tracker::OnMapLoaded(bool localization_only, bool may_start_own_map) {
  Reset();
  state_ = TrackingState::kLost;
  map_loaded_ = true;
  localization_only_ = localization_only;
  may_start_own_map_ = may_start_own_map && !localization_only &&
                       options_.tracking.start_outside_loaded_map;
}

void Tracker::OnInitialized(const Rigid3d& cam_from_world, const std::vector<Id>& landmark_ids,
                            Id current_keyframe_id, const Rigid3d& current_from_reference,
                            double keyframe_scale) {
  // The initialization's current frame (kept in last_frame_ by Track) is now a keyframe.
  last_frame_.cam_from_world = cam_from_world;
  last_frame_.has_pose = true;
  last_frame_.landmark_ids = landmark_ids;
  std::fill(last_frame_.is_outlier.begin(), last_frame_.is_outlier.end(), 0);
  last_frame_.reference_keyframe_id = current_keyframe_id;
  last_frame_from_reference_ = Rigid3d();
  last_frame_reference_scale_ = keyframe_scale;
  has_last_frame_ = true;
  last_frame_two_view_without_map_ = false;
  consecutive_two_view_frames_ = 0;
  // The motion over the initialization's span is the first velocity. Without it the first
  // frames after a turning start were predicted at rest, fell to relocalization frame after
  // frame, and each relocalization held keyframes back until tracking was lost (KITTI 00 from
  // frame 100). It is taken from the map, not from cam_from_world: a registration into a line
  // cloud moves the map away from the reference-at-origin frame.
  velocity_.reset();
  const double span = last_frame_.timestamp - initialization_reference_timestamp_;
  if (span > 0.0) {
    velocity_ = current_from_reference;
    velocity_dt_ = span;
  }
  state_ = TrackingState::kTracking;
  awaiting_map_ = false;
  frames_since_keyframe_ = 0;
  consecutive_lost_ = 0;
  initializer_.Reset();
  FrameRecord record;
  record.frame_id = last_frame_.id;
  record.timestamp = last_frame_.timestamp;
  record.reference_keyframe_id = current_keyframe_id;
  record.cam_from_world = cam_from_world;
  records_.push_back(record);
  initialization_frames_pending_ = true;
}

void Tracker::ReanchorLastFrame(const LocalMapSnapshot& snapshot) {
  const SnapshotKeyframe* reference = snapshot.FindKeyframe(last_frame_.reference_keyframe_id);
  if (reference == nullptr) return;
  // A Sim(3) correction (loop, merge) rescaled the map here: the offset and the velocity follow.
  if (reference->scale != last_frame_reference_scale_) {
    last_frame_from_reference_ =
        RescaledOffset(last_frame_from_reference_, last_frame_reference_scale_, reference->scale);
    if (velocity_) {
      velocity_ = RescaledOffset(*velocity_, last_frame_reference_scale_, reference->scale);
    }
    last_frame_reference_scale_ = reference->scale;
  }
  last_frame_.cam_from_world = last_frame_from_reference_ * reference->cam_from_world;
  last_frame_.cam_from_world.rotation.normalize();
}

Rigid3d Tracker::PredictPose(double timestamp) const {
  if (!velocity_) return last_frame_.cam_from_world;
  if (!(velocity_dt_ > 0.0)) return *velocity_ * last_frame_.cam_from_world;
  const double ratio = (timestamp - last_frame_.timestamp) / velocity_dt_;
  // The usual case, one frame period later: the velocity itself (no Log/Exp round trip).
  if (std::abs(ratio - 1.0) < 0.25) return *velocity_ * last_frame_.cam_from_world;
  // A gap (or a velocity measured across one): scale the motion to the elapsed time.
  const double scaled =
      std::clamp(ratio, 0.0, options_.tracking.max_extrapolation_seconds / velocity_dt_);
  return Rigid3d::Exp(scaled * velocity_->Log()) * last_frame_.cam_from_world;
}

int Tracker::MatchLastFrame(const LocalMapSnapshot& snapshot, float radius_factor, Frame* frame) {
  candidates_.clear();
  const ScaleLevels& levels = frame->scale_levels;
  for (int i = 0; i < last_frame_.num_keypoints(); ++i) {
    const Id id = last_frame_.landmark_ids[i];
    if (id == kInvalidId || last_frame_.is_outlier[i]) continue;
    const SnapshotLandmark* landmark = snapshot.FindLandmark(id);
    if (landmark == nullptr) continue;
    const Keypoint& kp = last_frame_.keypoints[i];
    ProjectionCandidate c;
    c.landmark_id = id;
    c.position_in_world = landmark->position_in_world;
    c.descriptor = landmark->descriptor;
    c.min_octave = std::max(0, kp.octave - 1);
    c.max_octave = kp.octave + 1;
    c.radius_px = static_cast<float>(options_.tracking.motion_search_radius_px * radius_factor *
                                     levels.Scale(kp.octave));
    c.reference_angle_deg = kp.angle_deg;
    candidates_.push_back(c);
  }
  ProjectionMatchOptions match_options;
  match_options.max_hamming_distance = 100;
  match_options.ratio = 1.f;
  match_options.check_orientation = true;
  match_options.num_threads = options_.tracking.search_threads;
  return MatchByProjection(candidates_, frame->cam_from_world, match_options, frame,
                           &match_scratch_);
}

int Tracker::TrackLastFrame(const LocalMapSnapshot& snapshot, Frame* frame) {
  int matches = MatchLastFrame(snapshot, 1.f, frame);
  if (matches < options_.tracking.min_motion_matches) {
    frame->ResetMatches();
    matches = MatchLastFrame(snapshot, 2.f, frame);
  }
  return matches >= options_.tracking.min_motion_matches ? OptimizePose(snapshot, frame) : 0;
}

int Tracker::MatchLocalMap(const LocalMapSnapshot& snapshot, Frame* frame, bool wide) {
  // Landmarks already matched in the frame are not candidates again.
  std::vector<Id> matched;
  matched.reserve(frame->num_keypoints());
  for (int i = 0; i < frame->num_keypoints(); ++i) {
    if (frame->landmark_ids[i] != kInvalidId && !frame->is_outlier[i]) {
      matched.push_back(frame->landmark_ids[i]);
    }
  }
  std::sort(matched.begin(), matched.end());

  const Camera& camera = *frame->camera;
  const ScaleLevels& levels = frame->scale_levels;
  const Rigid3d& pose = frame->cam_from_world;
  const Eigen::Matrix3d R = pose.RotationMatrix();
  const Eigen::Vector3d center = pose.Center();
  const double max_view_deg = wide ? std::max(90.0, options_.tracking.max_view_angle_deg)
                                    : options_.tracking.max_view_angle_deg;
  const double cos_max_view = std::cos(max_view_deg * M_PI / 180.0);
  const double near_factor = wide ? 0.5 : 0.8;
  const double far_factor = wide ? 2.0 : 1.2;
  const float radius_factor = options_.tracking.local_map_radius_factor * (wide ? 4.f : 1.f);
  const double cos_max_camera = std::cos(std::min(camera.MaxViewAngle(), M_PI));
  candidates_.clear();
  for (const SnapshotLandmark& landmark : snapshot.landmarks) {
    if (std::binary_search(matched.begin(), matched.end(), landmark.id)) continue;
    const Eigen::Vector3d p_in_cam = R * landmark.position_in_world + pose.translation;
    const double distance = p_in_cam.norm();
    if (!(distance > 0.0) || p_in_cam.z() / distance < cos_max_camera - 1e-12) continue;
    if (distance < near_factor * landmark.min_distance ||
        distance > far_factor * landmark.max_distance) {
      continue;
    }
    const Eigen::Vector3d ray = (landmark.position_in_world - center) / distance;
    const double view_cos = ray.dot(landmark.mean_viewing_direction);
    if (view_cos < cos_max_view) continue;
    const int octave = levels.PredictOctave(distance, landmark.max_distance);
    ProjectionCandidate c;
    c.landmark_id = landmark.id;
    c.position_in_world = landmark.position_in_world;
    c.descriptor = landmark.descriptor;
    c.min_octave = std::max(0, octave - 1);
    c.max_octave = octave;
    c.radius_px =
        static_cast<float>(radius_factor * (view_cos > 0.998 ? 2.5 : 4.0) * levels.Scale(octave));
    candidates_.push_back(c);
  }
  ProjectionMatchOptions match_options;
  match_options.max_hamming_distance = 100;
  match_options.ratio = 0.8f;
  match_options.check_orientation = false;
  match_options.num_threads = options_.tracking.search_threads;
  return MatchByProjection(candidates_, pose, match_options, frame, &match_scratch_);
}

int Tracker::MatchLocalLines(const LocalMapSnapshot& snapshot, Frame* frame, bool backoff) {
  if (!options_.line_cloud.match_lines || snapshot.lines.empty()) return 0;
  // Only lines without an X' in the window: an X' was already searched by projection at its
  // point (MatchLocalMap), so a second search along its whole line would cost the most (the
  // line's samples) for the keypoints least likely to be there (measured: 10 ms of a 23 ms
  // frame on the equirectangular tracking sequence, where most window lines have an X').
  backoff = backoff && line_search_backoff_.enabled();
  if (backoff) line_search_backoff_.StartFrame();
  line_candidates_.clear();
  for (const SnapshotLine& line : snapshot.lines) {
    if (!line.has_descriptor || !line.has_interval) continue;
    if (line.restored_landmark_id != kInvalidId &&
        snapshot.FindLandmark(line.restored_landmark_id) != nullptr) {
      continue;
    }
    if (backoff && !line_search_backoff_.ShouldSearch(line.id)) {
      ++lines_backed_off_;
      continue;
    }
    LineMatchCandidate c;
    c.line_id = line.id;
    c.line = line.line;
    c.s_min = line.s_min;
    c.s_max = line.s_max;
    c.descriptor = line.descriptor;
    c.has_viewers = line.has_viewers;
    c.viewers_centroid = line.viewers_centroid;
    line_candidates_.push_back(c);
  }
  line_matches_.clear();
  const int matched_lines = MatchLinesByProjection(line_candidates_, frame->cam_from_world,
                                                   options_.line_cloud.matching, frame,
                                                   &line_scratch_, &line_matches_);
  lines_searched_ += static_cast<int>(line_candidates_.size());
  if (backoff) {
    // Every searched line as a miss, then the matched ones (which forget their misses).
    for (size_t c = 0; c < line_candidates_.size(); ++c) {
      line_search_backoff_.Record(line_candidates_[c].line_id,
                                  line_scratch_.best_per_line[c].num_windows > 0,
                                  /*matched=*/false);
    }
    for (const LineMatch& match : line_matches_) {
      line_search_backoff_.Record(match.line_id, true, /*matched=*/true);
    }
  }
  // A line that has an X' in the window is matched as that X' (a map point of the client).
  for (const LineMatch& match : line_matches_) {
    const SnapshotLine* line = snapshot.FindLine(match.line_id);
    if (line != nullptr && snapshot.FindLandmark(line->restored_landmark_id) != nullptr) {
      frame->landmark_ids[match.keypoint_index] = line->restored_landmark_id;
    }
  }
  return matched_lines;
}

namespace {

// How far apart two cam_from_world poses are: centre distance (map units) and rotation angle.
struct PoseSeparation {
  double distance = 0.0;
  double angle_deg = 0.0;
};
PoseSeparation Separation(const Rigid3d& a, const Rigid3d& b) {
  return {(a.Center() - b.Center()).norm(), a.rotation.angularDistance(b.rotation) * 180.0 / M_PI};
}

}  // namespace

double LineCloudCheckTimeBudget(const SystemOptions& options, double min_frame_interval_s) {
  if (!options.live || !(options.tracking.line_cloud_check_live_periods > 0.0)) return 0.0;
  const double period = min_frame_interval_s > 0.0 ? min_frame_interval_s : 0.1;
  return options.tracking.line_cloud_check_live_periods * period;
}

int LineCloudCheckRetriesLeft(int retries_left, bool was_retry, bool unanswered,
                              int max_retries) {
  if (!unanswered) return 0;
  return was_retry ? std::max(0, retries_left - 1) : max_retries;
}

bool LineCloudCheckRefuses(const LineCloudPoseCheckResult& check,
                           const Rigid3d& tracked_cam_from_world, double median_depth,
                           const TrackingSettings& settings) {
  // No confident independent localization: nothing contradicts the tracked pose.
  if (check.num_inliers < settings.line_cloud_check_min_inliers) return false;
  // Both must disagree: p6L's matches, and its pose (p6L's pose alone can be off, its matches
  // partly wrong; see TrackingSettings::line_cloud_check_agreement for the measured cases).
  const bool matches_agree =
      check.num_agreeing >= settings.line_cloud_check_agreement * check.num_inliers;
  const PoseSeparation apart = Separation(check.cam_from_world, tracked_cam_from_world);
  const double max_distance = settings.line_cloud_check_depth_fraction * median_depth;
  const bool poses_agree = !(median_depth > 0.0 && apart.distance > max_distance) &&
                           apart.angle_deg <= settings.line_cloud_check_max_deg;
  return !matches_agree && !poses_agree;
}

bool Tracker::TrackFromLineCloudPose(const LocalMapSnapshot& snapshot,
                                     const LineCloudPoseCheckResult& check, Frame* frame,
                                     int* inliers) {
  const TrackingSettings& settings = options_.tracking;
  if (check.num_inliers < settings.line_cloud_check_min_inliers) return false;
  const PoseSeparation apart = Separation(check.cam_from_world, frame->cam_from_world);
  // The same pose, as far as the local map can tell: nothing to compare.
  if (apart.distance <= settings.line_cloud_retrack_min_depth_fraction *
                            snapshot.reference_median_distance &&
      apart.angle_deg <= settings.line_cloud_retrack_min_deg) {
    return false;
  }
  const int kept_line_inliers = last_num_line_inliers_;
  const int kept_new_line_inliers = last_num_new_line_inliers_;
  Frame alternative = *frame;
  alternative.ResetMatches();
  alternative.cam_from_world = check.cam_from_world;
  MatchLocalMap(snapshot, &alternative);
  MatchLocalLines(snapshot, &alternative, /*backoff=*/false);
  const int alternative_inliers = OptimizePose(snapshot, &alternative);
  if (alternative_inliers > *inliers) {
    *frame = std::move(alternative);
    *inliers = alternative_inliers;
    return true;
  }
  last_num_line_inliers_ = kept_line_inliers;
  last_num_new_line_inliers_ = kept_new_line_inliers;
  return false;
}

TrackingOutput Tracker::Track(Frame frame, const LocalMapSnapshot* snapshot, bool mapping_idle) {
  TrackingOutput out;
  lines_searched_ = lines_backed_off_ = 0;
  out.result.frame_id = frame.id;
  out.result.timestamp = frame.timestamp;
  out.result.num_keypoints = frame.num_keypoints();
  if (last_seen_timestamp_) {
    const double interval = frame.timestamp - *last_seen_timestamp_;
    if (interval > 0.0 && (min_frame_interval_s_ == 0.0 || interval < min_frame_interval_s_))
      min_frame_interval_s_ = interval;
  }
  last_seen_timestamp_ = frame.timestamp;

  if (state_ == TrackingState::kInitializing || snapshot == nullptr) {
    out.result.state = TrackingState::kInitializing;
    if (awaiting_map_) {
      // The map of the last initialization is being built: posed once it exists.
      BufferInitializationFrame(frame);
      return out;
    }
    StageTimer initializer_timer(&out.result.stages.initializer_ms);
    std::optional<Initialization> init = initializer_.TryInitialize(frame);
    if (init) {
      initialization_reference_timestamp_ = initializer_.reference().timestamp;
      initialization_reference_id_ = initializer_.reference().id;
      TrackingOutput::InitializationRequest request;
      request.reference = initializer_.reference();
      request.current = frame;
      request.initialization = std::move(*init);
      out.initialization = std::move(request);
      last_frame_ = std::move(frame);
      awaiting_map_ = true;
    } else {
      BufferInitializationFrame(frame);
    }
    initializer_timer.Stop();
    return out;
  }
  if (initialization_frames_pending_) {
    StageTimer timer(&out.result.stages.initialization_frames_ms);
    PoseInitializationFrames(*snapshot);
  }
  const int consecutive_lost_before = consecutive_lost_;

  // Motion model (while a last frame exists), then the local-map recovery.
  int inliers = 0;
  bool pose_ok = false;
  bool motion_model_failed = false;  // after a tracked frame: a keyframe is due (keyframe_policy.h)
  bool recovered = false;  // the recovery search, not the motion model, gave the pose
  // The last frame was relocalized on the writer without matches (OnRelocalized): this one is
  // posed by the local map searched from its pose, as a frame relocalized inline is.
  const bool from_relocalized_pose = has_last_frame_ && track_local_map_from_last_pose_;
  track_local_map_from_last_pose_ = false;
  Rigid3d predicted;
  if (from_relocalized_pose) {
    frame.cam_from_world = last_frame_.cam_from_world;
    frame.cam_from_world.rotation.normalize();
    frame.has_pose = true;
    pose_ok = true;
  } else if (has_last_frame_) {
    StageTimer motion_timer(&out.result.stages.motion_ms);
    ReanchorLastFrame(*snapshot);
    predicted = PredictPose(frame.timestamp);
    // Products of quaternions drift off the unit sphere; renormalize what is carried over.
    predicted.rotation.normalize();
    frame.cam_from_world = predicted;
    frame.has_pose = true;
    inliers = TrackLastFrame(*snapshot, &frame);
    if (inliers < options_.tracking.min_motion_matches && AdoptReferenceLandmarks(*snapshot)) {
      // Weak, and the last frame became a keyframe: again with the points it triangulated.
      frame.ResetMatches();
      frame.cam_from_world = predicted;
      inliers = TrackLastFrame(*snapshot, &frame);
    }
    pose_ok = inliers >= 10;
    motion_model_failed = !pose_ok && consecutive_lost_before == 0;  // relocalization below
    motion_timer.Stop();
    if (inliers < options_.tracking.min_motion_matches) {
      StageTimer recovery_timer(&out.result.stages.recovery_ms);
      const WeakMotionChoice choice = ChooseAfterWeakMotion(*snapshot, predicted, pose_ok, &frame);
      pose_ok = choice.score >= 10;
      recovered = pose_ok && !choice.motion_model;
      if (recovered) motion_model_failed = consecutive_lost_before == 0;
    }
  }

  // Relocalization in the whole map; local-map tracking then runs in the window around the
  // keyframe the frame was found against.
  std::shared_ptr<const LocalMapSnapshot> relocalization_snapshot;
  if (!pose_ok && async_relocalization_ && frame.num_keypoints() > 0) {
    StageTimer relocalization_timer(&out.result.stages.relocalization_ms);
    Frame request = frame;
    request.ResetMatches();
    out.relocalization_request = std::move(request);
  } else if (!pose_ok && relocalize_ && frame.num_keypoints() > 0) {
    StageTimer relocalization_timer(&out.result.stages.relocalization_ms);
    frame.ResetMatches();
    relocalization_snapshot = relocalize_(&frame);
    if (relocalization_snapshot) {
      snapshot = relocalization_snapshot.get();
      pose_ok = true;
      out.relocalized = true;
      out.result.relocalized = true;
      velocity_.reset();
    }
  }

  // Local map: points X and X', then the lines without a matched X' (Sec. 3.3).
  StageTimer local_map_timer(&out.result.stages.local_map_ms);
  last_num_line_inliers_ = 0;
  last_num_new_line_inliers_ = 0;
  line_cloud_tracking_ = !snapshot->lines.empty();
  if (pose_ok) {
    MatchLocalMap(*snapshot, &frame);
    MatchLocalLines(*snapshot, &frame);
    inliers = OptimizePose(*snapshot, &frame);
    // A pose found around the predicted one (the motion model, or the wide search after a gap)
    // is confirmed by the motion as well as by its matches, and it often sees the map from
    // further along, where fewer points match (a fast turn of a car at 5 Hz: KITTI 00's odd
    // frames were lost at 26 inliers and never recovered): it needs fewer inliers than a pose
    // from appearance alone (relocalization), and the weak tracking triggers a keyframe that
    // re-densifies the map.
    const int needed = out.relocalized || from_relocalized_pose
                           ? options_.tracking.min_tracked_inliers
                                       : std::min(options_.tracking.min_tracked_inliers,
                                                  options_.tracking.min_recovered_inliers);
    pose_ok = inliers >= needed;
    // Also a frame whose matches collapsed from the last one's (a camera that jumped while the
    // motion model still found enough matches at the predicted pose).
    const bool collapsed = consecutive_lost_before == 0 && last_num_inliers_ > 0 &&
                           inliers < options_.tracking.line_cloud_check_collapse * last_num_inliers_;
    // And the first frame tracked after lost ones: its pose came from a motion model that
    // failed on the frames before.
    // (Fisheye s1 after a jump: lost for 3 frames, then tracked 7 m off; re-tracked, 0.48 m.)
    const bool resumed = consecutive_lost_before > 0;
    // And, live, the frames after a check that its time budget cut short before it found a
    // confident pose: each gets a budget of its own (see line_cloud_check_live_retries).
    const bool retry = line_cloud_check_retries_left_ > 0;
    if (pose_ok && (recovered || collapsed || resumed || retry) && !out.relocalized &&
        !from_relocalized_pose &&
        snapshot->registered && line_cloud_pose_check_) {
      out.line_cloud_checked = true;
      // Live, the check shares the tracking thread's frame period (see the setting).
      const LineCloudPoseCheckOutcome outcome =
          line_cloud_pose_check_(frame, LineCloudCheckTimeBudget(options_, min_frame_interval_s_));
      out.line_cloud_check_cut_short = outcome.cut_short;
      const bool unanswered =
          outcome.cut_short && !(outcome.located && outcome.located->num_inliers >=
                                                        options_.tracking.line_cloud_check_min_inliers);
      line_cloud_check_retries_left_ =
          LineCloudCheckRetriesLeft(line_cloud_check_retries_left_, retry, unanswered,
                                    options_.tracking.line_cloud_check_live_retries);
      const std::optional<LineCloudPoseCheckResult>& check = outcome.located;
      if (check && TrackFromLineCloudPose(*snapshot, *check, &frame, &inliers)) {
        // As after a relocalization: the step from the last frame is no motion to extrapolate
        // (a camera that jumped went 19 m in one frame interval).
        out.line_cloud_check_adopted = true;
        velocity_.reset();
      } else if (check && LineCloudCheckRefuses(*check, frame.cam_from_world,
                                                snapshot->reference_median_distance,
                                                options_.tracking)) {
        pose_ok = false;
        out.line_cloud_check_refused = true;
      }
    }
  }
  local_map_timer.Stop();

  // The last resort right after a tracked frame: the pose relative to it from 2D-2D matches,
  // for a turn faster than the map can follow (slam/tracking_two_view.cc). Relocalization (which
  // resets the velocity when it succeeds, so that this runs on the tracking snapshot only) has
  // had its chance.
  bool two_view = false;
  if (!pose_ok && !out.line_cloud_check_refused && consecutive_lost_before == 0 &&
      TwoViewAllowed() && frame.num_keypoints() > 0) {
    StageTimer two_view_timer(&out.result.stages.two_view_ms);
    const int two_view_inliers = TrackByTwoView(*snapshot, &frame);
    if (two_view_inliers >= 0) {
      two_view = pose_ok = true;
      inliers = two_view_inliers;
      out.relocalization_request.reset();
      out.result.two_view = true;
      last_num_line_inliers_ = last_num_new_line_inliers_ = 0;
    }
  }

  out.result.num_matches = pose_ok ? inliers : 0;
  out.result.num_line_matches = pose_ok ? last_num_line_inliers_ : 0;
  out.result.num_lines_searched = lines_searched_;
  out.result.num_lines_backed_off = lines_backed_off_;
  if (!pose_ok) {
    out.result.state = TrackingState::kLost;
    out.relocalized = out.result.relocalized = false;
    ++consecutive_lost_;
    state_ = TrackingState::kLost;
    // Keep predicting from the last good pose (and relocalizing); after too long, start over,
    // unless the map is the user's and the camera has been in it.
    if (map_loaded_) {
      if (!loaded_map_first_timestamp_) loaded_map_first_timestamp_ = frame.timestamp;
      // Started outside the loaded map: a map of its own, which loop closing merges into the
      // loaded one on arrival (docs/slam.md "A camera that starts outside a loaded map").
      if (may_start_own_map_ && !tracked_in_loaded_map_ &&
          consecutive_lost_ >= options_.tracking.lost_after_frames &&
          frame.timestamp - *loaded_map_first_timestamp_ > options_.tracking.max_lost_seconds) {
        out.request_reset = true;
      }
    } else {
      // The line cloud placed the camera where this map's window is not: start a new map there
      // at once (the registered one is kept) instead of relocalizing in this one for seconds.
      if (out.line_cloud_check_refused) out.request_reset = true;
      const bool long_lost = consecutive_lost_ >= options_.tracking.lost_after_frames;
      const bool small_map = snapshot->map_num_keyframes <= 5;
      const bool too_long = frame.timestamp - last_tracked_timestamp_ >
                            options_.tracking.max_lost_seconds;
      const bool can_relocalize = relocalize_ || async_relocalization_;
      if (can_relocalize ? (long_lost && (small_map || too_long)) : long_lost) {
        out.request_reset = true;
      }
    }
    return out;
  }

  StageTimer keyframe_decision_timer(&out.result.stages.keyframe_decision_ms);
  consecutive_lost_ = 0;
  tracked_in_loaded_map_ = tracked_in_loaded_map_ || map_loaded_;
  last_tracked_timestamp_ = frame.timestamp;
  last_num_inliers_ = inliers;
  state_ = TrackingState::kTracking;
  out.result.state = TrackingState::kTracking;
  out.result.cam_from_world = frame.cam_from_world;
  frame.cam_from_world.rotation.normalize();
  // After a relocalization the last frame's pose is from before it, possibly far back; but when
  // only this frame failed (the previous one was tracked), the two poses still give the motion.
  // Without it, a camera relocalized in the middle of a turn was predicted at rest on the next
  // frame and lost again for 30 frames (synthetic loop, perspective, seed 3, frame 106).
  const bool previous_frame_tracked = consecutive_lost_before == 0 && has_last_frame_ &&
                                      velocity_dt_ > 0.0 &&
                                      frame.timestamp - last_frame_.timestamp < 1.5 * velocity_dt_;
  if (has_last_frame_ && (!out.relocalized || previous_frame_tracked) &&
      !out.line_cloud_check_adopted) {
    velocity_ = frame.cam_from_world * last_frame_.cam_from_world.Inverse();
    velocity_->rotation.normalize();
    velocity_dt_ = frame.timestamp - last_frame_.timestamp;
  }
  // ORB-SLAM waits about a second after a relocalization before inserting keyframes, but only
  // in a map of more than that many keyframes (a young map needs its keyframes), and only after
  // a real loss: a relocalization that replaced the motion model for one frame of a fast turn
  // must not starve the map of the keyframes the turn needs (synthetic loop, perspective: lost
  // again two frames later for 30 frames).
  if (out.relocalized && !previous_frame_tracked &&
      PauseKeyframesAfterRelocalization(*snapshot, frame.cam_from_world)) {
    frames_since_keyframe_ = -options_.keyframe_policy.max_frames;
  }

  ++frames_since_keyframe_;
  KeyframeDecisionInput decision;
  decision.frames_since_last_keyframe = frames_since_keyframe_;
  // Points X only, as the reference keyframe's count (LocalMapSnapshot::reference_num_tracked):
  // the policy judges the client's own map. Counting X' and lines held keyframes back until the
  // client's own points ran out (measured on the overlap pairs: 13 keyframes in 100 frames).
  decision.num_tracked = inliers - last_num_line_inliers_;
  decision.num_line_cloud_tracked = last_num_line_inliers_;
  decision.reference_num_tracked = snapshot->reference_num_tracked;
  decision.reference_num_restored = snapshot->reference_num_restored;
  decision.sees_all_around =
      frame.camera != nullptr && frame.camera->model() == CameraModel::kEquirectangular;
  decision.mapping_idle = mapping_idle;
  decision.motion_model_failed = motion_model_failed;
  decision.two_view = two_view;
  decision.registered_in_line_cloud = snapshot->registered;

  // Anchor to the newest keyframe of the snapshot (also the policy's travel reference).
  frame.reference_keyframe_id = snapshot->reference_keyframe_id;
  const SnapshotKeyframe* reference = snapshot->FindKeyframe(frame.reference_keyframe_id);
  if (reference != nullptr && snapshot->reference_median_distance > 0.0) {
    const double travel =
        (frame.cam_from_world.Center() - reference->cam_from_world.Center()).norm();
    decision.travel_of_depth = travel / snapshot->reference_median_distance;
  }
  const Rigid3d frame_from_reference =
      reference ? frame.cam_from_world * reference->cam_from_world.Inverse() : Rigid3d();
  frame.reference_cam_from_world = reference ? reference->cam_from_world : Rigid3d();
  frame.reference_scale = reference ? reference->scale : 0.0;
  FrameRecord record;
  record.frame_id = frame.id;
  record.timestamp = frame.timestamp;
  record.reference_keyframe_id = reference ? frame.reference_keyframe_id : kInvalidId;
  record.frame_from_reference = frame_from_reference;
  record.reference_scale = reference ? reference->scale : 1.0;
  record.cam_from_world = frame.cam_from_world;
  records_.push_back(record);

  if (localization_only_) {
    for (int i = 0; i < frame.num_keypoints(); ++i) {
      if (frame.landmark_ids[i] != kInvalidId) out.tracked_landmark_ids.push_back(frame.landmark_ids[i]);
    }
  } else if (frames_since_keyframe_ > 0 && NeedNewKeyframe(decision, options_.keyframe_policy)) {
    out.keyframe_candidate = frame;
    out.result.is_keyframe = true;
    frames_since_keyframe_before_candidate_ = frames_since_keyframe_;
    frames_since_keyframe_ = 0;
  }
  last_frame_ = std::move(frame);
  has_last_frame_ = true;
  last_frame_two_view_without_map_ = two_view && inliers == 0;
  consecutive_two_view_frames_ = two_view ? consecutive_two_view_frames_ + 1 : 0;
  last_frame_from_reference_ = frame_from_reference;
  last_frame_reference_scale_ = record.reference_scale;
  keyframe_decision_timer.Stop();
  return out;
}

}  // namespace lcv::slam


