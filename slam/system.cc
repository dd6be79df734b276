#include "slam/system.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <stdexcept>
#include <thread>

#include <opencv2/core.hpp>

#include "slam/bow/vocabulary.h"
#include "slam/data/frame_anchor.h"
#include "slam/data/slam_map_import.h"
#include "slam/feature/orb_extractor.h"
#include "slam/module/global_bundle_adjustment.h"
#include "slam/module/loop_closer.h"
#include "slam/module/loop_detector.h"
#include "slam/module/relocalizer.h"
#include "slam/local_mapping.h"
#include "slam/tracking.h"
#include "slam/util/error.h"

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

}  // namespace

class System::Impl {
 public:
  Impl(const CameraParams& camera_params, const SystemOptions& options)
      : camera_params_(camera_params),
        options_(options),
        camera_(MakeCamera(camera_params)),
        extractor_(ExtractorOptions(options.features, *camera_)),
        scale_levels_(options.features.scale_factor, options.features.num_levels),
        tracker_(options),
        mapper_(*camera_, options) {
    const bool has_vocabulary = options_.vocabulary && !options_.vocabulary->empty();
    if (has_vocabulary && options_.relocalization.enabled) {
      tracker_.SetRelocalizer([this](Frame* frame) { return Relocalize(frame); });
    }
    loop_closing_ = options_.LoopClosingActive();
    if (!options_.deterministic) {
      mapping_thread_ = std::thread([this] { MappingLoop(); });
      if (loop_closing_) loop_thread_ = std::thread([this] { LoopClosingLoop(); });
    }
  }

  ~Impl() { Stop(); }

  FrameResult Track(const cv::Mat& image, const cv::Mat& mask, double timestamp) {
    const auto start = std::chrono::steady_clock::now();
    std::vector<Keypoint> keypoints;
    std::vector<OrbDescriptor> descriptors;
    extractor_.Extract(image, mask, &keypoints, &descriptors);
    return TrackFeatures(std::move(keypoints), std::move(descriptors), timestamp, start);
  }

  FrameResult TrackFeatures(std::vector<Keypoint> keypoints,
                            std::vector<OrbDescriptor> descriptors, double timestamp,
                            std::chrono::steady_clock::time_point start) {
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
    const double extraction_ms = MillisecondsSince(start);

    std::shared_ptr<const LocalMapSnapshot> snapshot = LatestSnapshot();
    TrackingOutput out = tracker_.Track(std::move(frame), snapshot.get(), MappingIdle());
    double mapping_ms = 0.0;
    if (out.relocalized) {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.relocalizations;
    }
    if (!out.tracked_landmark_ids.empty()) MoveLocalizationWindow(out.tracked_landmark_ids);

    if (out.request_reset) {
      DrainQueue();
      bool keep_records = false;
      {
        std::lock_guard<std::mutex> lock(mapper_mutex_);
        const SlamMap& map = mapper_.map();
        const int active_keyframes = map.NumKeyframesInSegment(map.active_segment());
        if (loop_closing_ && options_.loop_closing.merge_maps && active_keyframes > 5) {
          mapper_.ArchiveActiveSegment();
          std::lock_guard<std::mutex> stats_lock(stats_mutex_);
          ++stats_.maps_kept;
        } else {
          mapper_.DiscardActiveSegment();
        }
        // Frames anchored in kept segments come back if their segment is merged.
        keep_records = !mapper_.map().keyframes().empty();
        loop_detector_.Reset();
        ++map_generation_;
        PublishSnapshot(nullptr);
      }
      tracker_.Reset(keep_records);
    }
    if (out.initialization) {
      // The map is empty and the mapping thread idle: building it here does not race.
      DrainQueue();
      const auto map_start = std::chrono::steady_clock::now();
      std::optional<InitialMap> initial;
      {
        std::lock_guard<std::mutex> lock(mapper_mutex_);
        initial = mapper_.Initialize(out.initialization->reference, out.initialization->current,
                                     out.initialization->initialization);
        loop_detector_.Reset();
        ++map_generation_;
        PublishSnapshot(mapper_.snapshot());
        CopyMappingStats();
      }
      if (initial) {
        tracker_.OnInitialized(initial->current_cam_from_world, initial->current_landmark_ids,
                               initial->current_keyframe_id, initial->current_from_reference,
                               initial->current_keyframe_scale);
        ++num_initializations_;
        out.result.state = TrackingState::kTracking;
        out.result.cam_from_world = initial->current_cam_from_world;
        out.result.is_keyframe = true;
        int matches = 0;
        for (const Id id : initial->current_landmark_ids) matches += id != kInvalidId;
        out.result.num_matches = matches;
      } else {
        tracker_.Reset();
      }
      mapping_ms += MillisecondsSince(map_start);
    }
    if (out.keyframe_candidate) {
      if (options_.deterministic) {
        const auto map_start = std::chrono::steady_clock::now();
        mapper_.ProcessKeyframe(*out.keyframe_candidate);
        PublishSnapshot(mapper_.snapshot());
        CopyMappingStats();
        if (loop_closing_ && DetectAndCorrectLoops() &&
            options_.loop_closing.global_bundle_adjustment) {
          const auto ba_start = std::chrono::steady_clock::now();
          GlobalBAJob job = CaptureGlobalBA(mapper_.map(), options_.line_cloud.global_ba_frees_line_cloud);
          SolveGlobalBA(GlobalBAOptionsFromSettings(), &job);
          ApplyGlobalBAJob(job, MillisecondsSince(ba_start));
        }
        mapping_ms += MillisecondsSince(map_start);
      } else {
        // Waiting for room in the bounded queue is mapping back-pressure, not tracking work.
        const auto wait_start = std::chrono::steady_clock::now();
        Enqueue(std::move(*out.keyframe_candidate));
        mapping_ms += MillisecondsSince(wait_start);
      }
    }
    out.result.extraction_ms = extraction_ms;
    out.result.mapping_ms = mapping_ms;
    out.result.tracking_ms = MillisecondsSince(start) - mapping_ms;
    return out.result;
  }

  void Finish() {
    if (finished_) return;
    DrainQueue();
    Stop();
    finished_ = true;
    std::lock_guard<std::mutex> lock(mapper_mutex_);
    CopyMappingStats();
  }

  void LoadMap(const Map& map) {
    LCV_CHECK(next_frame_id_ == 0) << "LoadMap after the first frame";
    // ImportSlamMap throws std::invalid_argument naming what makes the map unusable.
    SlamMap slam_map = ImportSlamMap(map, *camera_, scale_levels_);
    std::lock_guard<std::mutex> lock(mapper_mutex_);
    if (slam_map.keyframes().empty()) {
      // A line cloud alone: the client initializes in its own frame and registers into it.
      mapper_.LoadLineCloud(std::move(slam_map));
    } else {
      mapper_.LoadMap(std::move(slam_map));
      tracker_.OnMapLoaded(options_.localization_only);
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
  }

  SystemStats Stats() const {
    std::lock_guard<std::mutex> lock(stats_mutex_);
    return stats_;
  }

  std::vector<TimedPose> FrameTrajectory() const {
    const SlamMap& map = mapper_.map();
    // Frames of the active segment only (the others are in frames of their own).
    std::map<Id, const SlamKeyframe*> keyframe_of_frame;
    for (const auto& [id, kf] : map.keyframes()) {
      if (kf.segment == map.active_segment()) keyframe_of_frame[kf.source_frame_id] = &kf;
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
        if (!anchored || map.FindKeyframe(anchor)->segment != map.active_segment()) continue;
        pose.cam_from_world = *anchored;
      }
      out.push_back(pose);
    }
    return out;
  }

  std::vector<TimedPose> KeyframeTrajectory() const {
    std::vector<TimedPose> out;
    const SlamMap& map = mapper_.map();
    for (const auto& [id, kf] : map.keyframes()) {
      if (kf.segment == map.active_segment()) out.push_back({id, kf.timestamp, kf.cam_from_world});
    }
    return out;
  }

  Map ExportMap() const {
    Map map = mapper_.map().ToMap(camera_params_, 0);
    map.description = "lcv slam";
    return map;
  }

  // While the mapping threads run, the tracking thread (progress lines) reads the counts kept by
  // RefreshMapCounts, never the map the mapping thread is changing (issue 16: a data race).
  int NumKeyframes() const {
    if (!finished_ && !options_.deterministic) return num_keyframes_.load();
    const SlamMap& map = mapper_.map();
    return map.NumKeyframesInSegment(map.active_segment());
  }
  int NumLandmarks() const {
    if (!finished_ && !options_.deterministic) return num_landmarks_.load();
    return CountLandmarks();
  }
  int NumInitializations() const { return num_initializations_; }


  const Camera& camera() const { return *camera_; }

 private:
  // Tracking's relocalization hook: BoW candidates + PnP in the whole map. Waits for the
  // mapping thread to finish its keyframe (the map is read under its lock); a lost tracker has
  // no real-time budget to keep anyway.
  std::shared_ptr<const LocalMapSnapshot> Relocalize(Frame* frame) {
    std::lock_guard<std::mutex> lock(mapper_mutex_);
    if (mapper_.map().keyframes().empty()) return nullptr;
    RelocalizerOptions reloc_options;
    reloc_options.max_candidates = options_.relocalization.max_candidates;
    reloc_options.min_inliers = options_.relocalization.min_inliers;
    const std::optional<RelocalizationResult> result =
        slam::Relocalize(*options_.vocabulary, mapper_.database(), mapper_.map(), reloc_options,
                         options_.seed + frame->id, frame);
    if (!result) return nullptr;
    std::shared_ptr<const LocalMapSnapshot> snapshot = mapper_.PublishAround(result->keyframe_id);
    PublishSnapshot(snapshot);
    return snapshot;
  }

  // Localization-only mode has no keyframes to move the local-map window: recentre it on the
  // keyframe that shares most landmarks with the frame (ORB-SLAM's UpdateLocalKeyFrames).
  void MoveLocalizationWindow(const std::vector<Id>& tracked_landmark_ids) {
    std::lock_guard<std::mutex> lock(mapper_mutex_);
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

  GlobalBAOptions GlobalBAOptionsFromSettings() const {
    GlobalBAOptions ba_options;
    ba_options.max_iterations = options_.loop_closing.global_ba_iterations;
    ba_options.derived_virtual_information = options_.line_cloud.derived_virtual_information;
    return ba_options;
  }

  // Loop detection for the keyframes mapped since the last call and, on a loop, its
  // correction. Caller holds mapper_mutex_ (or runs deterministic). True when corrected.
  bool DetectAndCorrectLoops() {
    bool corrected = false;
    for (const Id id : mapper_.TakeNewKeyframeIds()) {
      if (corrected || mapper_.map().FindKeyframe(id) == nullptr) continue;
      if (DetectAndCorrectLineCloudLoop(id)) {
        corrected = true;
        continue;
      }
      std::optional<LoopDetection> loop =
          loop_detector_.Detect(mapper_.map(), mapper_.database(), id, options_.seed + id);
      if (!loop) continue;
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
      const LoopCorrectionReport report =
          CorrectLoop(*loop, LoopCloserOptions(), mapper_.mutable_map());
      event.closed = report.success;
      {
        std::lock_guard<std::mutex> lock(stats_mutex_);
        ++stats_.loops_detected;
        if (report.success) {
          ++stats_.loops_closed;
          ++stats_.pose_graph_runs;
          stats_.pose_graph_ms += report.pose_graph.time_ms;
        }
        stats_.loops.push_back(event);
      }
      if (report.success) {
        mapper_.Republish();
        PublishSnapshot(mapper_.snapshot());
        corrected = true;
      }
    }
    return corrected;
  }

  // Loop closing against the line cloud for keyframe id (caller as DetectAndCorrectLoops).
  bool DetectAndCorrectLineCloudLoop(Id id) {
    const LineCloudSettings& settings = options_.line_cloud;
    if (!settings.close_loops || !mapper_.map().ActiveSegmentRegistered()) return false;
    if (++keyframes_since_line_cloud_loop_ <= settings.loop.min_keyframes_between_loops) {
      return false;
    }
    std::optional<LineCloudLoopDetection> loop =
        DetectLineCloudLoop(options_.vocabulary.get(), mapper_.server_database(), id,
                            settings.loop, options_.seed + id, mapper_.map());
    if (!loop) return false;
    const LineCloudLoopCorrection correction =
        CorrectLineCloudLoop(*loop, settings.loop, mapper_.mutable_map());
    LoopEvent event;
    event.line_cloud = true;
    event.query_keyframe_id = id;
    event.match_keyframe_id = correction.anchor_keyframe_id;
    event.timestamp = mapper_.map().FindKeyframe(id)->timestamp;
    event.num_matches = loop->registration.num_inliers;
    event.closed = correction.report.success;
    {
      std::lock_guard<std::mutex> lock(stats_mutex_);
      ++stats_.loops_detected;
      if (event.closed) {
        ++stats_.loops_closed;
        ++stats_.pose_graph_runs;
        stats_.pose_graph_ms += correction.report.pose_graph.time_ms;
      }
      stats_.loops.push_back(event);
    }
    if (!event.closed) return false;
    keyframes_since_line_cloud_loop_ = 0;
    mapper_.Republish();
    PublishSnapshot(mapper_.snapshot());
    return true;
  }

  // Applies a solved global BA job to the map (caller holds mapper_mutex_ or is deterministic).
  void ApplyGlobalBAJob(const GlobalBAJob& job, double solve_ms = 0.0) {
    const auto start = std::chrono::steady_clock::now();
    // A job captured before a later loop correction is stale and not applied.
    if (!ApplyGlobalBA(job, mapper_.mutable_map())) return;
    mapper_.Republish();
    PublishSnapshot(mapper_.snapshot());
    std::lock_guard<std::mutex> lock(stats_mutex_);
    ++stats_.global_ba_runs;
    stats_.global_ba_ms += solve_ms + MillisecondsSince(start);
  }

  // The loop-closing thread: wakes after each mapped keyframe, detects and corrects loops with
  // the mapper paused (mapper_mutex_), then runs global BA on a copy of the map without holding
  // the lock, so that tracking and mapping go on, and merges the result back.
  void LoopClosingLoop() {
    for (;;) {
      {
        std::unique_lock<std::mutex> lock(loop_mutex_);
        loop_ready_.wait(lock, [&] { return loop_stop_ || loop_pending_; });
        if (!loop_pending_ && loop_stop_) return;
        loop_pending_ = false;
        loop_busy_ = true;
      }
      bool corrected = false;
      GlobalBAJob job;
      {
        std::lock_guard<std::mutex> lock(mapper_mutex_);
        if (mapper_.snapshot() != nullptr) corrected = DetectAndCorrectLoops();
        if (corrected && options_.loop_closing.global_bundle_adjustment) {
          job = CaptureGlobalBA(mapper_.map(), options_.line_cloud.global_ba_frees_line_cloud);
          job_generation_ = map_generation_;
        }
      }
      if (corrected && options_.loop_closing.global_bundle_adjustment) {
        const auto start = std::chrono::steady_clock::now();
        SolveGlobalBA(GlobalBAOptionsFromSettings(), &job);
        const double solve_ms = MillisecondsSince(start);
        std::lock_guard<std::mutex> lock(mapper_mutex_);
        // A reset while BA ran leaves nothing to apply it to.
        if (mapper_.snapshot() != nullptr && map_generation_ == job_generation_) {
          ApplyGlobalBAJob(job, solve_ms);
        }
      }
      {
        std::lock_guard<std::mutex> lock(loop_mutex_);
        loop_busy_ = false;
      }
      loop_idle_.notify_all();
    }
  }

  void NotifyLoopClosing() {
    if (!loop_thread_.joinable()) return;
    {
      std::lock_guard<std::mutex> lock(loop_mutex_);
      loop_pending_ = true;
    }
    loop_ready_.notify_one();
  }

  void StopLoopClosing() {
    if (!loop_thread_.joinable()) return;
    {
      std::unique_lock<std::mutex> lock(loop_mutex_);
      loop_idle_.wait(lock, [&] { return !loop_pending_ && !loop_busy_; });
      loop_stop_ = true;
    }
    loop_ready_.notify_all();
    loop_thread_.join();
  }

  std::shared_ptr<const LocalMapSnapshot> LatestSnapshot() {
    std::lock_guard<std::mutex> lock(snapshot_mutex_);
    return snapshot_;
  }
  int CountLandmarks() const {
    const SlamMap& map = mapper_.map();
    int count = 0;
    for (const auto& [id, landmark] : map.landmarks()) {
      count += landmark.segment == map.active_segment();
    }
    return count;
  }
  // Caller holds mapper_mutex_ (or runs deterministic). Every change of the map ends with a
  // PublishSnapshot, which calls this.
  void RefreshMapCounts() {
    const SlamMap& map = mapper_.map();
    num_keyframes_.store(map.NumKeyframesInSegment(map.active_segment()));
    num_landmarks_.store(CountLandmarks());
  }
  void PublishSnapshot(std::shared_ptr<const LocalMapSnapshot> snapshot) {
    RefreshMapCounts();
    std::lock_guard<std::mutex> lock(snapshot_mutex_);
    snapshot_ = std::move(snapshot);
  }

  bool MappingIdle() {
    if (options_.deterministic) return true;
    std::lock_guard<std::mutex> lock(queue_mutex_);
    return queue_.empty() && !mapping_busy_;
  }

  void Enqueue(Frame frame) {
    std::unique_lock<std::mutex> lock(queue_mutex_);
    // Bounded: tracking waits rather than letting mapping fall arbitrarily behind.
    queue_space_.wait(lock, [&] {
      return static_cast<int>(queue_.size()) < options_.mapping.keyframe_queue_capacity;
    });
    queue_.push_back(std::move(frame));
    queue_ready_.notify_one();
  }

  void DrainQueue() {
    if (options_.deterministic) return;
    std::unique_lock<std::mutex> lock(queue_mutex_);
    queue_space_.wait(lock, [&] { return queue_.empty() && !mapping_busy_; });
  }

  void MappingLoop() {
    for (;;) {
      Frame frame;
      {
        std::unique_lock<std::mutex> lock(queue_mutex_);
        queue_ready_.wait(lock, [&] { return stop_ || !queue_.empty(); });
        if (queue_.empty()) return;  // stop requested and nothing left
        frame = std::move(queue_.front());
        queue_.pop_front();
        mapping_busy_ = true;
      }
      {
        std::lock_guard<std::mutex> lock(mapper_mutex_);
        if (mapper_.snapshot() != nullptr) {
          mapper_.ProcessKeyframe(frame);
          PublishSnapshot(mapper_.snapshot());
          CopyMappingStats();
        }
      }
      NotifyLoopClosing();
      {
        std::lock_guard<std::mutex> lock(queue_mutex_);
        mapping_busy_ = false;
      }
      queue_space_.notify_all();
    }
  }

  // Caller holds mapper_mutex_ (or runs deterministic).
  void CopyMappingStats() {
    const SlamMap& map = mapper_.map();
    std::lock_guard<std::mutex> lock(stats_mutex_);
    stats_.local_ba_runs = mapper_.num_local_ba_runs();
    stats_.local_ba_ms = mapper_.local_ba_ms();
    if (!stats_.line_cloud) return;
    stats_.line_cloud_attempts = mapper_.line_cloud_attempts();
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
    if (map.ActiveSegmentRegistered()) {
      int restored = 0;
      for (const auto& [id, line] : map.lines()) {
        const SlamLandmark* x = map.FindLandmark(line.restored_landmark_id);
        restored += x != nullptr && x->segment == map.active_segment();
      }
      stats_.restored_points = restored;
    }
  }

  // Stops the mapping thread (after its queue), then the loop-closing thread (after its pending
  // detection and global BA, so that the final map includes them).
  void Stop() {
    if (mapping_thread_.joinable()) {
      {
        std::lock_guard<std::mutex> lock(queue_mutex_);
        stop_ = true;
      }
      queue_ready_.notify_all();
      mapping_thread_.join();
    }
    StopLoopClosing();
  }

  CameraParams camera_params_;
  SystemOptions options_;
  std::unique_ptr<Camera> camera_;
  OrbExtractor extractor_;
  ScaleLevels scale_levels_;
  Tracker tracker_;
  LocalMapper mapper_;
  Id next_frame_id_ = 0;
  int num_initializations_ = 0;
  int keyframes_since_line_cloud_loop_ = 0;  // keyframes checked since the last line-cloud loop
  bool finished_ = false;
  std::atomic<int> num_keyframes_{0}, num_landmarks_{0};  // see RefreshMapCounts
  bool loop_closing_ = false;
  LoopDetector loop_detector_{LoopDetectorOptions()};
  // Incremented by every reset or initialization (under mapper_mutex_): a global BA captured
  // from an older map is dropped.
  std::uint64_t map_generation_ = 0;
  std::uint64_t job_generation_ = 0;

  mutable std::mutex stats_mutex_;
  SystemStats stats_;

  std::mutex snapshot_mutex_;
  std::shared_ptr<const LocalMapSnapshot> snapshot_;

  // Guards mapper_ between the mapping thread and the (rare) resets and initializations.
  std::mutex mapper_mutex_;
  std::mutex queue_mutex_;
  std::condition_variable queue_ready_;
  std::condition_variable queue_space_;
  std::deque<Frame> queue_;
  bool mapping_busy_ = false;
  bool stop_ = false;
  std::thread mapping_thread_;

  // Loop-closing thread: woken after each mapped keyframe.
  std::mutex loop_mutex_;
  std::condition_variable loop_ready_;
  std::condition_variable loop_idle_;
  bool loop_pending_ = false;
  bool loop_busy_ = false;
  bool loop_stop_ = false;
  std::thread loop_thread_;
};

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
                              std::chrono::steady_clock::now());
}
void System::Finish() { impl_->Finish(); }
std::vector<TimedPose> System::FrameTrajectory() const { return impl_->FrameTrajectory(); }
std::vector<TimedPose> System::KeyframeTrajectory() const { return impl_->KeyframeTrajectory(); }
Map System::ExportMap() const { return impl_->ExportMap(); }
int System::NumKeyframes() const { return impl_->NumKeyframes(); }
int System::NumLandmarks() const { return impl_->NumLandmarks(); }
int System::NumInitializations() const { return impl_->NumInitializations(); }
const Camera& System::camera() const { return impl_->camera(); }
void System::LoadMap(const Map& map) { impl_->LoadMap(map); }
SystemStats System::Stats() const { return impl_->Stats(); }

}  // namespace lcv::slam
