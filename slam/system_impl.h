#pragma once
// System's implementation (internal to slam/system.cc and slam/map_writer.cc; not for other
// includers). Thread roles (docs/slam.md "Threads"):
//
// - tracking: the caller of TrackImage. Owns tracker_, extractor_ and the pending hand-overs
//   (futures); reads snapshots; never touches mapper_ while the writer thread runs.
// - the map's writer: the mapping thread (inline in deterministic mode). Owns mapper_ (SlamMap,
//   BowDatabase), map_generation_ and the loop stage's input slot. Runs WriterTasks in order:
//   keyframes, initialization, reset, relocalization, localization-window moves, loop
//   corrections and global BA results.
// - loop closing: slam/loop_closing.h, on copies; corrections go through the writer.
//
// Locks (none of them held across a solve, I/O or a callback): the writer's task queue
// (slam/map_writer_queue.h), snapshot_mutex_ (the published snapshot pointer), stats_mutex_ (stats_), and the loop
// stage's input slot. There is no map lock: only the writer touches the map.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "slam/data/frame.h"
#include "slam/data/local_map_snapshot.h"
#include "slam/feature/orb_extractor.h"
#include "slam/local_mapping.h"
#include "slam/loop_closing.h"
#include "slam/map_writer_queue.h"
#include "slam/module/line_cloud_localizer.h"
#include "slam/system.h"
#include "slam/tracking.h"
#include "slam/util/lock_timing.h"
#include "slam/util/thread_clock.h"

namespace lcv::slam {

class System::Impl : public LoopCorrectionWriter {
 public:
  Impl(const CameraParams& camera_params, const SystemOptions& options);
  ~Impl() override;

  // ---- Tracking thread (slam/system.cc) ----
  FrameResult Track(const cv::Mat& image, const cv::Mat& mask, double timestamp);
  FrameResult TrackFeatures(std::vector<Keypoint> keypoints, std::vector<OrbDescriptor> descriptors,
                            double timestamp, const ThreadClock& start);
  void Finish();
  void LoadMap(const Map& map);
  SystemStats Stats() const;
  std::vector<TimedPose> FrameTrajectory(int segment = -1) const;  // -1: the output segment
  std::vector<TimedPose> KeyframeTrajectory() const;
  Map ExportMap(int segment = -1) const;
  // output: the output segment when the caller has it (SlamMap::OutputSegment otherwise).
  std::vector<int> LeftOutMaps(int output = -1) const;
  int TrajectoryMap() const { return mapper_.map().OutputSegment(); }
  int NumKeyframes() const;
  int NumLandmarks() const;
  int NumInitializations() const { return num_initializations_; }
  const Camera& camera() const { return *camera_; }

  // ---- LoopCorrectionWriter (called by the loop stage; run on the writer) ----
  LoopCorrectionOutcome CorrectLoop(const LoopDetection& loop, std::uint64_t generation) override;
  LoopCorrectionOutcome CorrectLineCloudLoop(const LineCloudLoopDetection& loop,
                                             std::uint64_t generation) override;
  void ApplyGlobalBA(GlobalBAJob job, double solve_ms, std::uint64_t generation) override;

 private:
  // Results the writer hands back to tracking (polled, never waited for, in threaded mode).
  struct InitializationOutcome {
    std::optional<InitialMap> initial;
  };
  struct ResetOutcome {
    bool keep_records = false;  // the map kept a segment (or an older one) to re-anchor to
  };
  struct RelocalizationOutcome {
    std::optional<Frame> frame;  // relocalized: pose, reference keyframe, inlier matches
    std::shared_ptr<const LocalMapSnapshot> snapshot;
  };

  // Tracking side (slam/system.cc).
  // Applies the writer's answers that are ready (threaded mode).
  void TakeHandOvers();
  // The relocalization answer, if any (wait: block for it). True when it posed a frame.
  bool TakeRelocalization(bool wait);
  // mapping: the time the input spent on (inline) or waiting for (offline) the writer.
  void HandleInitialization(TrackingOutput* out, ThreadClockSpan* mapping);
  void HandleKeyframeCandidate(TrackingOutput* out, ThreadClockSpan* mapping);
  std::shared_ptr<const LocalMapSnapshot> LatestSnapshot();
  bool MappingIdle();

  // Writer side (slam/map_writer.cc). Run on the writer thread, or inline in deterministic mode.
  void WriterLoop();
  // Queues a task for the writer (inline in deterministic mode).
  void RunOnWriter(std::function<void()> work);
  // Keyframe admission: waits for room (wait) or refuses when the keyframe queue is full.
  bool PushKeyframe(Frame&& frame, bool wait);
  void DrainWriter();
  void StopWriter();
  void MapKeyframe(const Frame& frame);
  InitializationOutcome InitializeMap(const TrackingOutput::InitializationRequest& request);
  ResetOutcome ResetMap();
  // BoW candidates + PnP in the whole map; on success a snapshot around the keyframe found
  // (published) and the frame's pose and inlier matches set.
  std::shared_ptr<const LocalMapSnapshot> RelocalizeFrame(Frame* frame);
  // Lost frames go to RelocalizeFrame (inline when deterministic, else on the writer); once.
  void EnableRelocalization();
  bool relocalization_enabled_ = false;
  // RelocalizeFrame's second try, p6L in the line cloud (docs/slam.md "A lost frame
  // relocalized in the line cloud"); nullptr when it does not apply or finds no pose.
  std::shared_ptr<const LocalMapSnapshot> RelocalizeFrameInLineCloud(Frame* frame);
  void MoveLocalizationWindow(const std::vector<Id>& tracked_landmark_ids);
  // Corrects a loop detected by the loop stage (the writer's part of DetectAndCorrectLoops).
  LoopCorrectionOutcome CorrectDetectedLoop(const LoopDetection& detected, std::uint64_t generation,
                                            bool capture_global_ba);
  // Runs a correction on the writer (inline in deterministic mode) and waits for it.
  LoopCorrectionOutcome CorrectOnWriter(
      const std::function<LoopCorrectionOutcome(bool capture_global_ba)>& correct);
  // Counts a corrected (or rejected) loop and, when closed, republishes and captures global
  // BA's job.
  LoopCorrectionOutcome FinishLoopCorrection(const LoopEvent& event, double pose_graph_ms,
                                             bool capture_global_ba);
  // The same for a loop against the line cloud (slam/module/line_cloud_loop.h).
  LoopCorrectionOutcome CorrectDetectedLineCloudLoop(const LineCloudLoopDetection& detected,
                                                     std::uint64_t generation,
                                                     bool capture_global_ba);
  // Global BA's job from the live map: eq. 9 (lines and server keyframes free) when the map is
  // registered in a line cloud and LineCloud.global_ba_frees_line_cloud is on.
  GlobalBAJob CaptureGlobalBAJob() const;
  void ApplyGlobalBAJob(const GlobalBAJob& job, double solve_ms);
  // After a keyframe: loop detection inline, or a copy for the loop stage when its slot is free.
  void FeedLoopClosing();
  void PublishSnapshot(std::shared_ptr<const LocalMapSnapshot> snapshot);
  void RefreshMapCounts();
  int CountLandmarks() const;
  void CopyMappingStats();
  // Threaded mode, at the end of a run: hands the keyframes still waiting for the loop stage to
  // it and waits for their loops and global BA to be applied (see Stop).
  void FlushLoopClosing();
  void Stop();
  // The lock recorder of the calling thread's role (writer or tracking).
  LockHoldRecorder* WriterLocks() { return options_.deterministic ? &tracking_locks_ : &mapping_locks_; }

  CameraParams camera_params_;
  SystemOptions options_;
  std::unique_ptr<Camera> camera_;
  OrbExtractor extractor_;
  ScaleLevels scale_levels_;
  Tracker tracker_;
  LocalMapper mapper_;
  bool loop_closing_active_ = false;
  std::unique_ptr<LoopClosing> loop_closing_;
  // p6L on the loaded line cloud (as published), for the tracker's line-cloud check
  // (TrackingSettings::line_cloud_check_*) and the mapper's registration from keyframe views
  // (LineCloudSettings::view_registration); null without a matchable line cloud.
  std::unique_ptr<LineCloudLocalizer> line_cloud_localizer_;

  // Tracking thread's.
  Id next_frame_id_ = 0;
  int num_initializations_ = 0;
  bool finished_ = false;
  std::future<InitializationOutcome> pending_initialization_;
  std::future<ResetOutcome> pending_reset_;
  Id reset_first_kept_frame_id_ = kInvalidId;  // frames from this id on belong to the new map
  std::future<RelocalizationOutcome> pending_relocalization_;
  std::uint64_t tracker_epoch_ = 0;  // increases at every reset: older relocalizations are stale
  std::uint64_t relocalization_epoch_ = 0;
  std::atomic<bool> window_move_pending_{false};
  LockHoldRecorder tracking_locks_;

  // Writer's. Incremented by every reset or initialization: loops and global BA jobs of an
  // older map are dropped.
  std::uint64_t map_generation_ = 0;
  std::vector<Id> loop_pending_ids_;  // new keyframes not yet handed to the loop stage
  // The line cloud's server keyframe database, shared with the loop stage (made on first use;
  // constant once the line cloud is loaded).
  std::shared_ptr<const BowDatabase> server_database_;
  LockHoldRecorder mapping_locks_;

  std::atomic<int> num_keyframes_{0}, num_landmarks_{0};  // see RefreshMapCounts

  mutable std::mutex stats_mutex_;
  SystemStats stats_;

  std::mutex snapshot_mutex_;
  std::shared_ptr<const LocalMapSnapshot> snapshot_;
  // Incremented under snapshot_mutex_ with every publication; read by tracking without it.
  std::atomic<std::uint64_t> snapshot_version_{0};
  // Tracking's: the snapshot it last took and its version (LatestSnapshot).
  std::shared_ptr<const LocalMapSnapshot> tracking_snapshot_;
  std::uint64_t tracking_snapshot_version_ = 0;

  // The writer's task queue (keyframes bounded by MappingSettings::keyframe_queue_capacity; at
  // most one initialization, reset, relocalization and window move from tracking, and one loop
  // correction and one global BA result from loop closing outstanding at a time).
  MapWriterQueue writer_queue_;
  std::thread writer_thread_;
};

}  // namespace lcv::slam
