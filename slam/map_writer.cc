// System: the map's writer (docs/slam.md "Threads"). Everything here runs on the mapping thread
// (inline on the caller's thread in deterministic mode), the only thread that touches mapper_
// while the threads run; tracking and loop closing hand it tasks and get results back.

#include <algorithm>
#include <chrono>
#include <utility>

#include "slam/bow/vocabulary.h"
#include "slam/module/loop_closer.h"
#include "slam/module/relocalizer.h"
#include "slam/system_impl.h"
#include "slam/util/error.h"
#include "slam/util/thread_priority.h"

namespace lcv::slam {
namespace {

double MillisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

}  // namespace

// ---- The task queue ----

void System::Impl::RunOnWriter(std::function<void()> work) {
  if (options_.deterministic) {
    work();
    return;
  }
  // Callers are the tracking and loop-closing threads; only tracking's holds are recorded (the
  // loop stage's recorder is its own thread's).
  const bool queued = writer_queue_.PushTask(std::move(work));
  LCV_CHECK(queued) << "a task for the map's writer after it stopped";
}

bool System::Impl::PushKeyframe(Frame&& frame, bool wait) {
  return writer_queue_.PushKeyframe(std::move(frame), wait, &tracking_locks_);
}

bool System::Impl::MappingIdle() {
  if (options_.deterministic) return true;
  // Offline the input waits for mapping anyway: a keyframe is welcome whenever the queue has
  // room (it is mapped right after the current one), as inline. Live only when mapping is idle
  // (ORB-SLAM), so that a busy mapper is not handed keyframes it would make tracking wait for.
  if (!options_.live) return writer_queue_.HasKeyframeRoom();
  return writer_queue_.Idle();
}

void System::Impl::DrainWriter() {
  if (writer_thread_.joinable()) writer_queue_.WaitIdle();
}

void System::Impl::StopWriter() {
  if (!writer_thread_.joinable()) return;
  writer_queue_.Stop();
  writer_thread_.join();
}

void System::Impl::WriterLoop() {
  // Below tracking's priority (SystemOptions::background_nice): a frame gets the core first.
  std::string priority_error;
  const bool lowered = LowerCurrentThreadPriority(options_.background_nice, &priority_error);
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.mapping_thread_nice = CurrentThreadNice();
    if (!lowered) stats_.thread_priority_error = "mapping thread: " + priority_error;
  }
  while (std::optional<MapWriterQueue::Task> task = writer_queue_.Pop(&mapping_locks_)) {
    if (task->keyframe) {
      MapKeyframe(*task->keyframe);
    } else {
      task->work();
    }
    writer_queue_.Done(&mapping_locks_);
  }
}

// ---- Tasks ----

void System::Impl::MapKeyframe(const Frame& frame) {
  // A reset since the keyframe was queued leaves no map to add it to.
  if (mapper_.snapshot() == nullptr) return;
  mapper_.ProcessKeyframe(frame);
  PublishSnapshot(mapper_.snapshot());
  CopyMappingStats();
  FeedLoopClosing();
}

void System::Impl::FeedLoopClosing() {
  if (!loop_closing_active_) return;
  if (server_database_ == nullptr && mapper_.map().HasLineCloud()) {
    server_database_ = std::make_shared<const BowDatabase>(mapper_.server_database());
  }
  if (options_.deterministic) {
    if (loop_closing_->DetectAndCorrectLoops(mapper_.map(), mapper_.database(),
                                             server_database_.get(),
                                             mapper_.TakeNewKeyframeIds(), map_generation_) &&
        options_.loop_closing.global_bundle_adjustment) {
      const auto ba_start = std::chrono::steady_clock::now();
      GlobalBAJob job = CaptureGlobalBAJob();
      SolveGlobalBA(loop_closing_->GlobalBAOptionsFromSettings(), &job);
      ApplyGlobalBAJob(job, MillisecondsSince(ba_start));
    }
    return;
  }
  for (const Id id : mapper_.TakeNewKeyframeIds()) loop_pending_ids_.push_back(id);
  // The copy is made only when the stage can take it; otherwise the ids wait for the next one.
  if (loop_pending_ids_.empty() || !loop_closing_->CanPost()) return;
  const auto copy_start = std::chrono::steady_clock::now();
  LoopClosingInput input;
  input.map = std::make_shared<const SlamMap>(mapper_.map());
  input.server_database = server_database_;
  const double copy_ms = MillisecondsSince(copy_start);
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.loop_input_copies;
    stats_.loop_input_copy_ms += copy_ms;
    stats_.loop_input_copy_max_ms = std::max(stats_.loop_input_copy_max_ms, copy_ms);
  }
  input.new_keyframe_ids = loop_pending_ids_;
  input.generation = map_generation_;
  const int num_ids = static_cast<int>(loop_pending_ids_.size());
  if (loop_closing_->Post(std::move(input), &mapping_locks_)) {
    loop_pending_ids_.clear();
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.loop_input_keyframes += num_ids;
  }
}

System::Impl::InitializationOutcome System::Impl::InitializeMap(
    const TrackingOutput::InitializationRequest& request) {
  InitializationOutcome outcome;
  outcome.initial = mapper_.Initialize(request.reference, request.current, request.initialization);
  ++map_generation_;
  loop_pending_ids_.clear();
  PublishSnapshot(mapper_.snapshot());
  CopyMappingStats();
  return outcome;
}

System::Impl::ResetOutcome System::Impl::ResetMap() {
  const SlamMap& map = mapper_.map();
  const int active_keyframes = map.NumKeyframesInSegment(map.active_segment());
  // A map registered in a line cloud is kept whatever its size: it is in the server's frame
  // already, so its frames stay in the trajectory without a merge (docs/slam.md "Interruptions
  // in a line cloud").
  const bool in_line_cloud_frame = active_keyframes > 0 && map.ActiveSegmentRegistered();
  // A loaded map is the user's: kept whatever its size (a camera that started outside it).
  const bool loaded = map.SegmentWithLoadedKeyframes() == map.active_segment();
  if (in_line_cloud_frame || loaded ||
      (loop_closing_active_ && options_.loop_closing.merge_maps && active_keyframes > 5)) {
    mapper_.ArchiveActiveSegment();
    std::lock_guard<std::mutex> stats_lock(stats_mutex_);
    ++stats_.maps_kept;
  } else {
    mapper_.DiscardActiveSegment();
  }
  ResetOutcome outcome;
  // Frames anchored in kept segments come back if their segment is merged.
  outcome.keep_records = !mapper_.map().keyframes().empty();
  ++map_generation_;
  loop_pending_ids_.clear();
  PublishSnapshot(nullptr);
  CopyMappingStats();
  return outcome;
}

std::shared_ptr<const LocalMapSnapshot> System::Impl::RelocalizeFrame(Frame* frame) {
  if (mapper_.map().keyframes().empty()) return nullptr;
  if (!options_.vocabulary || options_.vocabulary->empty()) return RelocalizeFrameInLineCloud(frame);
  RelocalizerOptions reloc_options;
  reloc_options.max_candidates = options_.relocalization.max_candidates;
  reloc_options.min_inliers = options_.relocalization.min_inliers;
  const std::optional<RelocalizationResult> result =
      slam::Relocalize(*options_.vocabulary, mapper_.database(), mapper_.map(), reloc_options,
                       options_.seed + frame->id, frame);
  if (!result) return RelocalizeFrameInLineCloud(frame);
  std::shared_ptr<const LocalMapSnapshot> snapshot = mapper_.PublishAround(result->keyframe_id);
  PublishSnapshot(snapshot);
  return snapshot;
}

std::shared_ptr<const LocalMapSnapshot> System::Impl::RelocalizeFrameInLineCloud(Frame* frame) {
  const SlamMap& map = mapper_.map();
  if (!options_.relocalization.in_line_cloud || !line_cloud_localizer_ ||
      !map.ActiveSegmentRegistered() || map.LineCloudDetached()) {
    return nullptr;
  }
  // The predicted orientation first: a camera interrupted or thrown off in position mostly
  // keeps it (the localizer falls back to p6L when it does not hold).
  std::optional<Eigen::Quaterniond> rotation_prior;
  if (frame->has_pose) rotation_prior = frame->cam_from_world.rotation;
  const int max_trials = options_.live ? options_.relocalization.line_cloud_live_max_trials
                                      : options_.relocalization.line_cloud_max_trials;
  const LineCloudLocalization located = line_cloud_localizer_->Localize(
      frame->keypoints, frame->descriptors, max_trials, {}, frame->id, rotation_prior);
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.line_cloud_relocalization_attempts;
  }
  if (!located.success || located.num_inliers < options_.relocalization.line_cloud_min_inliers) {
    return nullptr;
  }
  // The frame's reference: the active segment's keyframe nearest to it (poses are kept relative
  // to a keyframe); the lines tracking needs are those around the frame itself.
  const Eigen::Vector3d centre = located.cam_from_world.Center();
  Id nearest = kInvalidId;
  double nearest_distance = 0.0;
  for (const auto& [id, keyframe] : map.keyframes()) {
    if (keyframe.segment != map.active_segment()) continue;
    const double distance = (keyframe.Center() - centre).squaredNorm();
    if (nearest == kInvalidId || distance < nearest_distance) {
      nearest = id;
      nearest_distance = distance;
    }
  }
  if (nearest == kInvalidId) return nullptr;
  frame->ResetMatches();
  frame->cam_from_world = located.cam_from_world;
  frame->has_pose = true;
  frame->reference_keyframe_id = nearest;
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.line_cloud_relocalizations;
  }
  std::shared_ptr<const LocalMapSnapshot> snapshot = mapper_.PublishAround(nearest, centre);
  PublishSnapshot(snapshot);
  return snapshot;
}

// Localization-only mode has no keyframes to move the local-map window: recentre it on the
// keyframe that shares most landmarks with the frame (ORB-SLAM's UpdateLocalKeyFrames).
void System::Impl::MoveLocalizationWindow(const std::vector<Id>& tracked_landmark_ids) {
  const SlamMap& map = mapper_.map();
  std::map<Id, int> votes;
  for (const Id id : tracked_landmark_ids) {
    const SlamLandmark* landmark = map.FindLandmark(id);
    if (landmark == nullptr) continue;
    for (const Observation& o : landmark->observations) ++votes[o.keyframe_id];
  }
  Id best = kInvalidId;
  int best_votes = 0;
  for (const auto& [id, count] : votes) {
    if (count > best_votes) best = id, best_votes = count;
  }
  const std::shared_ptr<const LocalMapSnapshot> current = mapper_.snapshot();
  if (best == kInvalidId || (current && current->reference_keyframe_id == best)) return;
  PublishSnapshot(mapper_.PublishAround(best));
}

// ---- Loop closing's hand-overs ----

LoopCorrectionOutcome System::Impl::CorrectOnWriter(
    const std::function<LoopCorrectionOutcome(bool capture_global_ba)>& correct) {
  if (options_.deterministic) return correct(false);
  // From the loop stage's thread: the writer does it between two of its tasks; the stage
  // waits (no lock held), tracking does not.
  auto promise = std::make_shared<std::promise<LoopCorrectionOutcome>>();
  std::future<LoopCorrectionOutcome> done = promise->get_future();
  const bool capture = options_.loop_closing.global_bundle_adjustment;
  RunOnWriter([promise, correct, capture] { promise->set_value(correct(capture)); });
  return done.get();
}

LoopCorrectionOutcome System::Impl::CorrectLoop(const LoopDetection& loop,
                                                std::uint64_t generation) {
  return CorrectOnWriter([this, loop, generation](bool capture) {
    return CorrectDetectedLoop(loop, generation, capture);
  });
}

LoopCorrectionOutcome System::Impl::CorrectLineCloudLoop(const LineCloudLoopDetection& loop,
                                                         std::uint64_t generation) {
  return CorrectOnWriter([this, loop, generation](bool capture) {
    return CorrectDetectedLineCloudLoop(loop, generation, capture);
  });
}

LoopCorrectionOutcome System::Impl::FinishLoopCorrection(const LoopEvent& event,
                                                         double pose_graph_ms,
                                                         bool capture_global_ba) {
  {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.loops_detected;
    if (event.closed) {
      ++stats_.loops_closed;
      ++stats_.pose_graph_runs;
      stats_.pose_graph_ms += pose_graph_ms;
    }
    stats_.loops.push_back(event);
  }
  LoopCorrectionOutcome outcome;
  if (event.closed) {
    mapper_.Republish();
    PublishSnapshot(mapper_.snapshot());
    outcome.closed = true;
    if (capture_global_ba) outcome.global_ba_job = CaptureGlobalBAJob();
  }
  return outcome;
}

LoopCorrectionOutcome System::Impl::CorrectDetectedLineCloudLoop(
    const LineCloudLoopDetection& loop, std::uint64_t generation, bool capture_global_ba) {
  if (generation != map_generation_ ||
      mapper_.map().FindKeyframe(loop.query_keyframe_id) == nullptr) {
    return LoopCorrectionOutcome();
  }
  const LineCloudLoopCorrection correction =
      slam::CorrectLineCloudLoop(loop, options_.line_cloud.loop, mapper_.mutable_map());
  LoopEvent event;
  event.line_cloud = true;
  event.query_keyframe_id = loop.query_keyframe_id;
  event.match_keyframe_id = correction.anchor_keyframe_id;
  event.timestamp = mapper_.map().FindKeyframe(loop.query_keyframe_id)->timestamp;
  event.num_matches = loop.registration.num_inliers;
  event.closed = correction.report.success;
  return FinishLoopCorrection(event, correction.report.pose_graph.time_ms, capture_global_ba);
}

GlobalBAJob System::Impl::CaptureGlobalBAJob() const {
  GlobalBACaptureOptions capture;
  capture.free_line_cloud = options_.line_cloud.global_ba_frees_line_cloud;
  capture.free_server_keyframes = options_.line_cloud.global_ba_frees_server_keyframes;
  capture.keep_server_datum = options_.line_cloud.global_ba_keeps_server_datum;
  capture.virtual_from_published = options_.line_cloud.virtual_from_published;
  capture.keep_loaded_datum = options_.loop_closing.keep_loaded_datum;
  return CaptureGlobalBA(mapper_.map(), capture);
}

void System::Impl::ApplyGlobalBA(GlobalBAJob job, double solve_ms, std::uint64_t generation) {
  auto shared_job = std::make_shared<GlobalBAJob>(std::move(job));
  RunOnWriter([this, shared_job, solve_ms, generation] {
    // A reset or initialization while BA ran leaves nothing to apply it to.
    if (generation != map_generation_ || mapper_.snapshot() == nullptr) return;
    ApplyGlobalBAJob(*shared_job, solve_ms);
  });
}

LoopCorrectionOutcome System::Impl::CorrectDetectedLoop(const LoopDetection& detected,
                                                        std::uint64_t generation,
                                                        bool capture_global_ba) {
  // Detected in a copy: the map may have been reset, or a side culled, since.
  if (generation != map_generation_ || mapper_.map().FindKeyframe(detected.query_keyframe_id) ==
                                           nullptr ||
      mapper_.map().FindKeyframe(detected.match_keyframe_id) == nullptr) {
    return LoopCorrectionOutcome();
  }
  std::optional<LoopDetection> loop = detected;
  const Id id = loop->query_keyframe_id;
  LoopEvent event;
  event.merged_maps = MergeSegmentsForLoop(&*loop, mapper_.mutable_map());
  if (event.merged_maps) {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.maps_merged;
  }
  event.query_keyframe_id = loop->query_keyframe_id;
  event.match_keyframe_id = loop->match_keyframe_id;
  event.timestamp = mapper_.map().FindKeyframe(id)->timestamp;
  event.num_matches = loop->num_inliers;
  LoopCloserOptions closer;
  closer.keep_loaded_datum = options_.loop_closing.keep_loaded_datum;
  const LoopCorrectionReport report = slam::CorrectLoop(*loop, closer, mapper_.mutable_map());
  event.closed = report.success;
  return FinishLoopCorrection(event, report.pose_graph.time_ms, capture_global_ba);
}

void System::Impl::ApplyGlobalBAJob(const GlobalBAJob& job, double solve_ms) {
  const auto start = std::chrono::steady_clock::now();
  SystemStats::GlobalBARun run;
  for (const BundleKeyframe& k : job.problem.keyframes) {
    const SlamKeyframe* keyframe = mapper_.map().FindKeyframe(k.id);
    if (keyframe != nullptr) run.timestamp = std::max(run.timestamp, keyframe->timestamp);
  }
  run.line_cloud = job.line_cloud;
  run.keyframes = static_cast<int>(job.problem.keyframes.size());
  run.server_keyframes = static_cast<int>(job.problem.server_keyframes.size());
  run.points = static_cast<int>(job.problem.points.size());
  run.lines = static_cast<int>(job.problem.lines.size());
  run.observations = static_cast<int>(job.problem.observations.size());
  run.virtual_observations = static_cast<int>(job.problem.virtual_observations.size());
  run.iterations = job.report.num_iterations;
  run.initial_cost = job.report.initial_cost;
  run.final_cost = job.report.final_cost;
  run.outliers = job.report.num_outliers;
  run.solve_ms = solve_ms;
  run.message = job.report.message;
  // A job captured before a later loop correction is stale and not applied.
  run.applied = slam::ApplyGlobalBA(job, mapper_.mutable_map());
  if (run.applied) {
    mapper_.Republish();
    PublishSnapshot(mapper_.snapshot());
  }
  std::lock_guard<std::mutex> lock(stats_mutex_);
  stats_.global_ba.push_back(run);
  if (!run.applied) return;
  ++stats_.global_ba_runs;
  stats_.global_ba_ms += solve_ms + MillisecondsSince(start);
}

// ---- Publication ----

int System::Impl::CountLandmarks() const {
  const SlamMap& map = mapper_.map();
  // Once the run is over, the count of what the outputs hold.
  const int segment = finished_ ? map.OutputSegment() : map.active_segment();
  int count = 0;
  for (const auto& [id, landmark] : map.landmarks()) count += landmark.segment == segment;
  return count;
}

// Every change of the map ends with a PublishSnapshot, which calls this: tracking reads these
// counts (progress lines), never the map (issue 16).
void System::Impl::RefreshMapCounts() {
  const SlamMap& map = mapper_.map();
  num_keyframes_.store(map.NumKeyframesInSegment(map.active_segment()));
  num_landmarks_.store(CountLandmarks());
}

void System::Impl::PublishSnapshot(std::shared_ptr<const LocalMapSnapshot> snapshot) {
  RefreshMapCounts();
  std::shared_ptr<const LocalMapSnapshot> previous;
  {
    TimedLock lock(snapshot_mutex_, WriterLocks());
    previous = std::move(snapshot_);
    snapshot_ = std::move(snapshot);
    // After the pointer: a reader that sees the new version finds the new pointer.
    snapshot_version_.fetch_add(1, std::memory_order_release);
  }
  // The old snapshot is freed outside the lock (it may be the last reference).
}

void System::Impl::CopyMappingStats() {
  const SlamMap& map = mapper_.map();
  std::lock_guard<std::mutex> lock(stats_mutex_);
  stats_.local_ba_runs = mapper_.num_local_ba_runs();
  stats_.local_ba_stopped_early = mapper_.num_local_ba_stopped_early();
  stats_.keyframes_reanchored = mapper_.num_keyframes_reanchored();
  stats_.local_ba_ms = mapper_.local_ba_ms();
  const int loaded_segment = map.SegmentWithLoadedKeyframes();
  const int output = map.OutputSegment();
  stats_.loaded_map = loaded_segment >= 0;
  stats_.trajectory_in_loaded_map_frame = loaded_segment == output;
  stats_.maps_left_out = static_cast<int>(LeftOutMaps(output).size());
  if (!stats_.line_cloud) return;
  stats_.trajectory_in_line_cloud_frame = map.SegmentInLineCloudFrame(output);
  stats_.line_cloud_attempts = mapper_.line_cloud_attempts();
  stats_.line_cloud_detachments = mapper_.line_cloud_detachments();
  stats_.restored_points_released = mapper_.restored_points_released();
  // The log only grows: copy the attempts made since the last call.
  const std::vector<SystemStats::LineCloudAttempt>& log = mapper_.line_cloud_attempt_log();
  if (log.size() > stats_.line_cloud_attempt_log.size()) {
    stats_.line_cloud_attempt_log.insert(stats_.line_cloud_attempt_log.end(),
                                         log.begin() + stats_.line_cloud_attempt_log.size(),
                                         log.end());
  }
  const LineCloudRelocalizationReport& report = mapper_.last_line_cloud_report();
  if (report.success && !stats_.relocalized_in_line_cloud) {
    stats_.relocalized_in_line_cloud = true;
    const SlamKeyframe* kf = map.FindKeyframe(report.keyframe_id);
    stats_.line_cloud_registration_timestamp = kf != nullptr ? kf->timestamp : 0.0;
    stats_.line_cloud_method = report.registration.method;
    stats_.line_cloud_inliers = report.registration.num_inliers;
    stats_.line_cloud_scale = report.registration.server_from_client.scale;
    stats_.line_cloud_registration_ms = report.time_ms;
  } else if (!report.success && report.keyframe_id != kInvalidId) {
    stats_.line_cloud_last_failure = report.failure;
  }
  if (map.SegmentInLineCloudFrame(output)) {
    int restored = 0;
    for (const auto& [id, line] : map.lines()) {
      const SlamLandmark* x = map.FindLandmark(line.restored_landmark_id);
      restored += x != nullptr && x->segment == output;
    }
    stats_.restored_points = restored;
  }
}

}  // namespace lcv::slam
