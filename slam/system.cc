#include "slam/system.h"

// System: the facade and the tracking thread's side (docs/slam.md "Threads"); the map's writer
// is in slam/map_writer.cc, loop closing in slam/loop_closing.cc.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <map>
#include <set>
#include <stdexcept>
#include <utility>

#include <opencv2/core.hpp>

#include "slam/bow/vocabulary.h"
#include "slam/data/frame_anchor.h"
#include "slam/data/slam_map_import.h"
#include "slam/solve/p6l.h"
#include "slam/system_impl.h"
#include "slam/util/error.h"
#include "slam/util/thread_clock.h"
#include "slam/util/thread_priority.h"

namespace lcv::slam {

const char* TrackingStateName(TrackingState state) {
  switch (state) {
    case TrackingState::kInitializing:
      return "initializing";
    case TrackingState::kTracking:
      return "tracking";
    case TrackingState::kLost:
      return "lost";
  }
  return "unknown";
}

bool SystemOptions::LoopClosingActive() const {
  return vocabulary && !vocabulary->empty() && loop_closing.enabled && !localization_only;
}

int DefaultNumFeatures(CameraModel model, int cols, int rows) {
  const double kitti_pixels = 1241.0 * 376.0;
  const double scaled = 2000.0 * static_cast<double>(cols) * rows / kitti_pixels;
  if (model == CameraModel::kEquirectangular) {
    return static_cast<int>(std::lround(std::clamp(2.0 * scaled, 2000.0, 4000.0)));
  }
  return static_cast<int>(std::lround(std::clamp(scaled, 1000.0, 2000.0)));
}

namespace {

double MillisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

OrbExtractorOptions ExtractorOptions(const FeatureSettings& features, const Camera& camera) {
  OrbExtractorOptions options;
  options.num_features = features.num_features;
  options.scale_factor = static_cast<float>(features.scale_factor);
  options.num_levels = features.num_levels;
  options.ini_fast_threshold = features.ini_fast_threshold;
  options.min_fast_threshold = features.min_fast_threshold;
  // The stretched poles of an equirectangular image make poor features.
  if (camera.model() == CameraModel::kEquirectangular) options.pole_mask_fraction = 0.1f;
  return options;
}

template <typename T>
bool Ready(const std::future<T>& future) {
  return future.valid() && future.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
}

}  // namespace

System::Impl::Impl(const CameraParams& camera_params, const SystemOptions& options)
    : camera_params_(camera_params),
      options_(options),
      camera_(MakeCamera(camera_params)),
      extractor_(ExtractorOptions(options.features, *camera_)),
      scale_levels_(options.features.scale_factor, options.features.num_levels),
      tracker_(options),
      mapper_(*camera_, options),
      writer_queue_(options.mapping.keyframe_queue_capacity) {
  const bool has_vocabulary = options_.vocabulary && !options_.vocabulary->empty();
  if (has_vocabulary && options_.relocalization.enabled) EnableRelocalization();
  // Live input: a local BA still running when tracking queues the next keyframe stops there, so
  // that the keyframe is mapped now instead of the one after it being refused.
  if (!options_.deterministic && options_.live) {
    mapper_.SetLocalBundleStop([this] { return writer_queue_.keyframes_queued() > 0; });
  }
  loop_closing_active_ = options_.LoopClosingActive();
  if (loop_closing_active_) loop_closing_ = std::make_unique<LoopClosing>(options_, this);
  if (!options_.deterministic) {
    writer_thread_ = std::thread([this] { WriterLoop(); });
    if (loop_closing_) loop_closing_->Start();
  }
}

System::Impl::~Impl() { Stop(); }

void System::Impl::EnableRelocalization() {
  if (relocalization_enabled_) return;
  relocalization_enabled_ = true;
  if (options_.deterministic) {
    tracker_.SetRelocalizer([this](Frame* frame) { return RelocalizeFrame(frame); });
  } else {
    tracker_.EnableAsyncRelocalization();
  }
}

FrameResult System::Impl::Track(const cv::Mat& image, const cv::Mat& mask, double timestamp) {
  const ThreadClock start = ThreadClock::Now();
  std::vector<Keypoint> keypoints;
  std::vector<OrbDescriptor> descriptors;
  extractor_.Extract(image, mask, &keypoints, &descriptors);
  return TrackFeatures(std::move(keypoints), std::move(descriptors), timestamp, start);
}

FrameResult System::Impl::TrackFeatures(std::vector<Keypoint> keypoints,
                                        std::vector<OrbDescriptor> descriptors, double timestamp,
                                        const ThreadClock& start) {
  LCV_CHECK(!finished_) << "TrackImage after Finish";
  LCV_CHECK(keypoints.size() == descriptors.size());
  Frame frame;
  frame.id = next_frame_id_++;
  frame.timestamp = timestamp;
  frame.camera = camera_.get();
  frame.scale_levels = scale_levels_;
  frame.keypoints = std::move(keypoints);
  frame.descriptors = std::move(descriptors);
  PrepareFrame(&frame);
  const double extraction_ms = MillisecondsSince(start.wall);

  // Time the input waited for the writer (offline) or spent mapping (inline): not tracking's.
  ThreadClockSpan mapping;
  double handover_ms = 0.0;
  StageTimer handover_timer(&handover_ms);
  TakeHandOvers();
  std::shared_ptr<const LocalMapSnapshot> snapshot = LatestSnapshot();
  const bool mapping_idle = MappingIdle();
  handover_timer.Stop();
  TrackingOutput out = tracker_.Track(std::move(frame), snapshot.get(), mapping_idle);
  out.result.stages.handover_ms = handover_ms;
  snapshot.reset();
  if (out.relocalized) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.relocalizations;
  }
  if (out.line_cloud_checked) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.line_cloud_checks;
    stats_.line_cloud_check_refusals += out.line_cloud_check_refused;
    stats_.line_cloud_check_adoptions += out.line_cloud_check_adopted;
    stats_.line_cloud_checks_cut_short += out.line_cloud_check_cut_short;
  }
  if (out.relocalization_request) {
    // At most one outstanding: a lost camera produces a request per frame, the writer serves one
    // at a time, and the newest frame is the one worth relocalizing next.
    if (pending_relocalization_.valid()) {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.relocalizations_skipped;
    } else {
      auto promise = std::make_shared<std::promise<RelocalizationOutcome>>();
      pending_relocalization_ = promise->get_future();
      relocalization_epoch_ = tracker_epoch_;
      auto request = std::make_shared<Frame>(std::move(*out.relocalization_request));
      RunOnWriter([this, promise, request] {
        RelocalizationOutcome outcome;
        outcome.snapshot = RelocalizeFrame(request.get());
        if (outcome.snapshot) outcome.frame = std::move(*request);
        promise->set_value(std::move(outcome));
      });
      // Offline the input waits for the answer (holding no lock), which then poses this frame.
      if (!options_.live) {
        const ThreadClock wait_start = ThreadClock::Now();
        if (TakeRelocalization(/*wait=*/true)) {
          const FrameRecord& record = tracker_.records().back();
          out.result.state = TrackingState::kTracking;
          out.result.cam_from_world = record.cam_from_world;
          out.result.relocalized = true;
        }
        mapping += ThreadClock::Now() - wait_start;
      }
    }
  }
  if (!out.tracked_landmark_ids.empty()) {
    if (options_.deterministic) {
      MoveLocalizationWindow(out.tracked_landmark_ids);
    } else if (!window_move_pending_.exchange(true)) {
      RunOnWriter([this, ids = std::move(out.tracked_landmark_ids)] {
        MoveLocalizationWindow(ids);
        window_move_pending_.store(false);
      });
    }
  }
  if (out.request_reset) {
    // Which segment is kept or dropped is the writer's decision, on its map.
    const ThreadClock reset_start = ThreadClock::Now();
    if (options_.deterministic) {
      tracker_.Reset(ResetMap().keep_records);
    } else {
      auto promise = std::make_shared<std::promise<ResetOutcome>>();
      pending_reset_ = promise->get_future();
      reset_first_kept_frame_id_ = next_frame_id_;
      RunOnWriter([this, promise] { promise->set_value(ResetMap()); });
      // Records are dropped later if the writer drops their segment (TakeHandOvers).
      tracker_.Reset(/*keep_records=*/true);
      ++tracker_epoch_;
      if (!options_.live) pending_reset_.wait();
    }
    mapping += ThreadClock::Now() - reset_start;
  }
  if (out.initialization) HandleInitialization(&out, &mapping);
  if (out.keyframe_candidate) HandleKeyframeCandidate(&out, &mapping);
  const ThreadClockSpan total = ThreadClock::Now() - start;
  out.result.extraction_ms = extraction_ms;
  out.result.mapping_ms = mapping.wall_ms;
  out.result.tracking_ms = total.wall_ms - mapping.wall_ms;
  out.result.tracking_cpu_ms = total.cpu_ms - mapping.cpu_ms;
  out.result.preemptions = total.preemptions - mapping.preemptions;
  return out.result;
}

void System::Impl::HandleInitialization(TrackingOutput* out, ThreadClockSpan* mapping) {
  const ThreadClock map_start = ThreadClock::Now();
  if (!options_.deterministic) {
    // The map is built (a 20-iteration BA) on the writer; tracking keeps the frames meanwhile
    // and takes the result on a later frame (TakeHandOvers).
    auto promise = std::make_shared<std::promise<InitializationOutcome>>();
    pending_initialization_ = promise->get_future();
    auto request = std::make_shared<TrackingOutput::InitializationRequest>(
        std::move(*out->initialization));
    RunOnWriter([this, promise, request] { promise->set_value(InitializeMap(*request)); });
    if (options_.live) {
      *mapping += ThreadClock::Now() - map_start;
      return;
    }
    // Offline the input waits for the map (as for room in the keyframe queue).
  }
  const InitializationOutcome outcome =
      options_.deterministic ? InitializeMap(*out->initialization) : pending_initialization_.get();
  if (outcome.initial) {
    const InitialMap& initial = *outcome.initial;
    tracker_.OnInitialized(initial.current_cam_from_world, initial.current_landmark_ids,
                           initial.current_keyframe_id, initial.current_from_reference,
                           initial.current_keyframe_scale);
    ++num_initializations_;
    out->result.state = TrackingState::kTracking;
    out->result.cam_from_world = initial.current_cam_from_world;
    out->result.is_keyframe = true;
    int matches = 0;
    for (const Id id : initial.current_landmark_ids) matches += id != kInvalidId;
    out->result.num_matches = matches;
  } else {
    tracker_.Reset();
  }
  *mapping += ThreadClock::Now() - map_start;
}

void System::Impl::HandleKeyframeCandidate(TrackingOutput* out, ThreadClockSpan* mapping) {
  const ThreadClock map_start = ThreadClock::Now();
  if (options_.deterministic) {
    MapKeyframe(*out->keyframe_candidate);
  } else if (!PushKeyframe(std::move(*out->keyframe_candidate), /*wait=*/!options_.live)) {
    // Live: mapping is behind and the queue is full; a camera does not wait. The tracker
    // proposes a later frame (ORB-SLAM's monocular NeedNewKeyFrame, which declines while local
    // mapping is busy).
    tracker_.OnKeyframeRefused();
    out->result.is_keyframe = false;
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.keyframes_refused;
  } else if (!options_.live) {
    // Offline the input waits until the keyframe is mapped, as inline: tracking the next frames
    // against a snapshot a keyframe or two old (the mapper behind a flat-out feeder) starves them
    // of the keyframe's new points in fast motion, and tracking was lost (issue 14). Loop
    // closing and global BA still run beside it. Mapping back-pressure, not tracking work.
    writer_queue_.WaitKeyframesMapped();
  }
  *mapping += ThreadClock::Now() - map_start;
}

void System::Impl::TakeHandOvers() {
  if (options_.deterministic) return;
  if (Ready(pending_reset_)) {
    if (!pending_reset_.get().keep_records) tracker_.DropRecordsBefore(reset_first_kept_frame_id_);
  }
  if (Ready(pending_initialization_)) {
    const InitializationOutcome outcome = pending_initialization_.get();
    if (outcome.initial) {
      const InitialMap& initial = *outcome.initial;
      tracker_.OnInitialized(initial.current_cam_from_world, initial.current_landmark_ids,
                             initial.current_keyframe_id, initial.current_from_reference,
                             initial.current_keyframe_scale);
      ++num_initializations_;
    } else {
      tracker_.Reset();
    }
  }
  TakeRelocalization(/*wait=*/false);
}

bool System::Impl::TakeRelocalization(bool wait) {
  if (!pending_relocalization_.valid() || (!wait && !Ready(pending_relocalization_))) {
    return false;
  }
  RelocalizationOutcome outcome = pending_relocalization_.get();
  if (relocalization_epoch_ != tracker_epoch_ || !outcome.frame ||
      !tracker_.OnRelocalized(std::move(*outcome.frame), *outcome.snapshot)) {
    return false;
  }
  std::lock_guard<std::mutex> lock(stats_mutex_);
  ++stats_.relocalizations;
  return true;
}

std::shared_ptr<const LocalMapSnapshot> System::Impl::LatestSnapshot() {
  // The lock only when the writer published since the last frame (after a keyframe, a loop
  // correction, a relocalization): most frames take no lock at all, and so cannot be preempted
  // while holding one. Whichever snapshot a frame gets is the latest one published before it
  // read the version, as with a locked read.
  if (snapshot_version_.load(std::memory_order_acquire) != tracking_snapshot_version_) {
    std::shared_ptr<const LocalMapSnapshot> previous;
    {
      TimedLock lock(snapshot_mutex_, &tracking_locks_);
      // Only pointer copies under the lock: the snapshot tracking had until now (often the last
      // reference to it) is released after it.
      previous = std::exchange(tracking_snapshot_, snapshot_);
      tracking_snapshot_version_ = snapshot_version_.load(std::memory_order_relaxed);
    }
  }
  return tracking_snapshot_;
}

void System::Impl::Stop() {
  // Keyframes first (they feed loop closing), then loop closing (its corrections and global BA
  // results go through the writer, which must still run), then what loop closing handed over.
  DrainWriter();
  FlushLoopClosing();
  if (loop_closing_) loop_closing_->Stop();
  DrainWriter();
  StopWriter();
}

void System::Impl::FlushLoopClosing() {
  // Keyframes mapped while the loop stage was busy wait in loop_pending_ids_ until the next
  // keyframe hands them over (FeedLoopClosing). At the end of a run there is no next keyframe:
  // a global BA that outlasts the rest of an offline sequence (frames come faster than real
  // time) left the last keyframes unexamined, and with them the loops they close. Measured on
  // the fisheye Table-3 loop pair, seed 3: the threaded client never examined the keyframes
  // after its first loop and missed the second one that the inline run closes (APE 0.22
  // against 0.12 m). They are handed over here, as inline runs examine every keyframe.
  if (options_.deterministic || !loop_closing_ || !writer_thread_.joinable()) return;
  // Each round waits for the stage (and the writer, which applies its corrections and global
  // BA), then hands over what is pending. No keyframe is mapped any more, so the ids run out:
  // a round that finds none ends it (the bound only guards against a stage that never idles).
  // FeedLoopClosing counts what it hands over in stats_.loop_input_keyframes.
  auto keyframes_handed_over = [this] {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    return stats_.loop_input_keyframes;
  };
  for (int round = 0; round < 8; ++round) {
    loop_closing_->WaitIdle();
    DrainWriter();
    const int before = keyframes_handed_over();
    RunOnWriter([this] { FeedLoopClosing(); });
    DrainWriter();
    const int handed_over = keyframes_handed_over() - before;
    if (handed_over == 0) break;
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.loop_input_keyframes_at_finish += handed_over;
  }
  loop_closing_->WaitIdle();
  RunOnWriter([this] {
    for (const Id id : mapper_.TakeNewKeyframeIds()) loop_pending_ids_.push_back(id);
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.loop_input_keyframes_unexamined = static_cast<int>(loop_pending_ids_.size());
  });
  DrainWriter();
}

void System::Impl::Finish() {
  if (finished_) return;
  Stop();
  finished_ = true;
  // The writer has stopped: its last results are ready.
  TakeHandOvers();
  if (const std::shared_ptr<const LocalMapSnapshot> snapshot = LatestSnapshot()) {
    tracker_.PosePendingInitializationFrames(*snapshot);
  }
  CopyMappingStats();
}

void System::Impl::LoadMap(const Map& map) {
  LCV_CHECK(next_frame_id_ == 0) << "LoadMap after the first frame";
  // ImportSlamMap throws std::invalid_argument naming what makes the map unusable.
  auto slam_map = std::make_shared<SlamMap>(ImportSlamMap(map, *camera_, scale_levels_));
  const bool has_keyframes = !slam_map->keyframes().empty();
  // A line cloud alone holds nothing a frame can be tracked against without a map of the
  // client's own: the client initializes, maps and registers into the cloud (paper Sec. 3.1),
  // so "track without changing the map" has no meaning there (it used to be accepted and
  // ignored: the client made its keyframes all the same).
  if (!has_keyframes && options_.localization_only) {
    throw std::invalid_argument(
        "a line cloud without keyframes cannot be tracked in localization-only mode "
        "(localization_only, lcv slam --localization-only): the LC-VSLAM client maps on its own "
        "to register into it and track in it (per-frame localization in a line cloud alone: "
        "p6L, lcv localize)");
  }
  // p6L in the line cloud: tracking's line-cloud check, and local mapping's registration from
  // several keyframes' poses when P4L / P3P fail. Localize is const and holds its own copy of
  // the lines (no map lock); the object lives as long as the System.
  if (!map.lines.empty()) {
    LineCloudLocalizerOptions localizer_options;
    localizer_options.random_seed = options_.seed;
    line_cloud_localizer_ =
        std::make_unique<LineCloudLocalizer>(map, *camera_, localizer_options);
    if (line_cloud_localizer_->num_matchable_lines() == 0) line_cloud_localizer_.reset();
  }
  const LineCloudLocalizer* localizer = line_cloud_localizer_.get();
  // p6L relocalizes lost frames in the line cloud without a vocabulary too.
  if (localizer && options_.relocalization.enabled && options_.relocalization.in_line_cloud) {
    EnableRelocalization();
  }
  // On the writer (the map's owner); before the first frame, so waiting costs no frame.
  auto promise = std::make_shared<std::promise<void>>();
  std::future<void> done = promise->get_future();
  RunOnWriter([this, promise, slam_map, has_keyframes, localizer] {
    try {
      mapper_.SetLineCloudLocalizer(localizer);
      if (!has_keyframes) {
        // A line cloud alone: the client initializes in its own frame and registers into it.
        mapper_.LoadLineCloud(std::move(*slam_map));
      } else {
        mapper_.LoadMap(std::move(*slam_map));
      }
      if (mapper_.map().HasLineCloud()) {
        const std::string problem = mapper_.PrepareLineCloud();
        std::lock_guard<std::mutex> stats_lock(stats_mutex_);
        stats_.line_cloud = true;
        stats_.line_cloud_problem = problem;
      }
      if (!mapper_.map().keyframes().empty()) {
        mapper_.Republish();
        PublishSnapshot(mapper_.snapshot());
      }
      CopyMappingStats();
      promise->set_value();
    } catch (...) {
      promise->set_exception(std::current_exception());
    }
  });
  done.get();
  // A camera that starts outside the map may start one of its own only where loop closing can
  // bring it back into the loaded one.
  if (has_keyframes) {
    tracker_.OnMapLoaded(options_.localization_only,
                         loop_closing_active_ && options_.loop_closing.merge_maps);
  }
  if (line_cloud_localizer_ && options_.tracking.line_cloud_check_agreement > 0.0) {
    // Called by the tracking thread on the rare recovered frame.
    tracker_.SetLineCloudPoseCheck(
        [this](const Frame& frame, double time_budget_s) -> LineCloudPoseCheckOutcome {
          // Live (a time budget), a check cut short is retried on the next frames with other
          // samples each time, and the tracked orientation is tried first: p6L's samples are too
          // slow to find a pose of mostly wrong matches within a frame period, and a camera
          // thrown off in position by a jump or a gap keeps its orientation (fisheye s2 after a
          // 19 m jump: p6L needed 250-860 samples, 0.4-1.4 s).
          const bool live = time_budget_s > 0.0;
          std::function<bool()> should_stop;
          if (live) {
            const auto deadline =
                std::chrono::steady_clock::now() +
                std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                    std::chrono::duration<double>(time_budget_s));
            should_stop = [deadline] { return std::chrono::steady_clock::now() >= deadline; };
          }
          const LineCloudLocalization located = line_cloud_localizer_->Localize(
              frame.keypoints, frame.descriptors, /*max_ransac_trials=*/0, should_stop,
              live ? frame.id : 0,
              live ? std::optional<Eigen::Quaterniond>(frame.cam_from_world.rotation)
                   : std::nullopt);
          LineCloudPoseCheckOutcome outcome;
          outcome.cut_short = located.stopped_early;
          if (!located.success) return outcome;
          LineCloudPoseCheckResult result{located.cam_from_world, located.num_inliers, 0};
          const double max_sin = std::sin(2.0 * line_cloud_localizer_->max_error_rad());
          for (size_t i = 0; i < located.inlier_lines.size(); ++i) {
            result.num_agreeing +=
                SquaredBearingPlaneError(frame.cam_from_world, located.inlier_bearings[i],
                                         located.inlier_lines[i]) <= max_sin * max_sin;
          }
          outcome.located = result;
          return outcome;
        });
  }
}

SystemStats System::Impl::Stats() const {
  SystemStats stats;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats = stats_;
  }
  // The other threads' recorders are theirs until they are joined.
  stats.map_lock_tracking = tracking_locks_.Summary();
  stats.tracking_thread_nice = CurrentThreadNice();
  if (finished_ && !options_.deterministic) {
    stats.map_lock_mapping = mapping_locks_.Summary();
    if (loop_closing_) {
      stats.map_lock_loop_closing = loop_closing_->lock_recorder().Summary();
      stats.loop_closing_thread_nice = loop_closing_->thread_nice();
      if (stats.thread_priority_error.empty()) {
        stats.thread_priority_error = loop_closing_->thread_priority_error();
      }
    }
  }
  if (options_.deterministic) {
    // One thread does it all.
    stats.mapping_thread_nice = stats.loop_closing_thread_nice = stats.tracking_thread_nice;
  }
  return stats;
}

namespace {

// The trajectories hold the output segment's frames (SlamMap::OutputSegment; the other segments
// are in frames of their own), and, when it is registered in a line cloud, those of every
// segment kept in the line cloud's frame too: a client that lost tracking and registered again.
bool InOutputFrame(const SlamMap& map, int segment, int output) {
  if (segment == output) return true;
  return map.SegmentInLineCloudFrame(output) && map.SegmentInLineCloudFrame(segment);
}

}  // namespace

std::vector<TimedPose> System::Impl::FrameTrajectory(int segment) const {
  const SlamMap& map = mapper_.map();
  const int output = segment >= 0 ? segment : map.OutputSegment();
  std::map<Id, const SlamKeyframe*> keyframe_of_frame;
  for (const auto& [id, kf] : map.keyframes()) {
    if (InOutputFrame(map, kf.segment, output)) keyframe_of_frame[kf.source_frame_id] = &kf;
  }
  std::vector<TimedPose> out;
  for (const FrameRecord& record : tracker_.records()) {
    TimedPose pose;
    pose.id = record.frame_id;
    pose.timestamp = record.timestamp;
    pose.cam_from_world = record.cam_from_world;
    auto kf = keyframe_of_frame.find(record.frame_id);
    if (kf != keyframe_of_frame.end()) {
      pose.cam_from_world = kf->second->cam_from_world;
    } else if (record.reference_keyframe_id != kInvalidId) {
      Id anchor = kInvalidId;
      const std::optional<Rigid3d> anchored =
          AnchoredFramePose(map, record.reference_keyframe_id, record.frame_from_reference,
                            record.reference_scale, &anchor);
      if (!anchored || !InOutputFrame(map, map.FindKeyframe(anchor)->segment, output)) continue;
      pose.cam_from_world = *anchored;
    }
    out.push_back(pose);
  }
  return out;
}

std::vector<TimedPose> System::Impl::KeyframeTrajectory() const {
  std::vector<TimedPose> out;
  const SlamMap& map = mapper_.map();
  const int output = map.OutputSegment();
  for (const auto& [id, kf] : map.keyframes()) {
    if (InOutputFrame(map, kf.segment, output)) {
      out.push_back({id, kf.timestamp, kf.cam_from_world});
    }
  }
  return out;
}

Map System::Impl::ExportMap(int segment) const {
  // A loaded map that the run's own map never joined is written instead of that map, so that
  // --map-in X --map-out X loses nothing (docs/slam.md "A camera that starts outside a loaded
  // map").
  const int loaded_segment = mapper_.map().SegmentWithLoadedKeyframes();
  if (segment < 0) segment = loaded_segment >= 0 ? loaded_segment : mapper_.map().OutputSegment();
  Map map = mapper_.map().ToMap(camera_params_, 0, segment);
  map.description = "lcv slam";
  return map;
}

std::vector<int> System::Impl::LeftOutMaps(int output) const {
  const SlamMap& map = mapper_.map();
  if (output < 0) output = map.OutputSegment();
  std::set<int> left_out;
  for (const auto& [id, kf] : map.keyframes()) {
    if (kf.loaded || InOutputFrame(map, kf.segment, output)) continue;
    left_out.insert(kf.segment);
  }
  return std::vector<int>(left_out.begin(), left_out.end());
}

// While the threads run, the tracking thread (progress lines) reads the counts kept by
// RefreshMapCounts, never the map the writer is changing (issue 16: a data race).
int System::Impl::NumKeyframes() const {
  if (!finished_ && !options_.deterministic) return num_keyframes_.load();
  const SlamMap& map = mapper_.map();
  // Once the run is over, the counts are those of what the outputs hold.
  return map.NumKeyframesInSegment(finished_ ? map.OutputSegment() : map.active_segment());
}

int System::Impl::NumLandmarks() const {
  if (!finished_ && !options_.deterministic) return num_landmarks_.load();
  return CountLandmarks();
}

System::System(const CameraParams& camera, const SystemOptions& options)
    : impl_(std::make_unique<Impl>(camera, options)) {}
System::~System() = default;

FrameResult System::TrackImage(const cv::Mat& image, double timestamp) {
  return impl_->Track(image, cv::Mat(), timestamp);
}
FrameResult System::TrackImage(const cv::Mat& image, const cv::Mat& mask, double timestamp) {
  return impl_->Track(image, mask, timestamp);
}
FrameResult System::TrackFeatures(std::vector<Keypoint> keypoints,
                                  std::vector<OrbDescriptor> descriptors, double timestamp) {
  return impl_->TrackFeatures(std::move(keypoints), std::move(descriptors), timestamp,
                              ThreadClock::Now());
}
void System::Finish() { impl_->Finish(); }
std::vector<TimedPose> System::FrameTrajectory() const { return impl_->FrameTrajectory(); }
std::vector<TimedPose> System::KeyframeTrajectory() const { return impl_->KeyframeTrajectory(); }
Map System::ExportMap() const { return impl_->ExportMap(); }
std::vector<int> System::LeftOutMaps() const { return impl_->LeftOutMaps(); }
std::vector<TimedPose> System::FrameTrajectory(int map) const {
  return impl_->FrameTrajectory(map);
}
Map System::ExportMap(int map) const { return impl_->ExportMap(map); }
int System::TrajectoryMap() const { return impl_->TrajectoryMap(); }
int System::NumKeyframes() const { return impl_->NumKeyframes(); }
int System::NumLandmarks() const { return impl_->NumLandmarks(); }
int System::NumInitializations() const { return impl_->NumInitializations(); }
const Camera& System::camera() const { return impl_->camera(); }
void System::LoadMap(const Map& map) { impl_->LoadMap(map); }
SystemStats System::Stats() const { return impl_->Stats(); }

}  // namespace lcv::slam
