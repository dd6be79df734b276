#pragma once
// The loop-closing stage of System (beside slam/tracking.h and slam/local_mapping.h; internal to
// the engine, exposed for tests). Per new keyframe: loop detection (slam/module/loop_detector.h);
// on a loop, the correction (segment merge, slam/module/loop_closer.h) and then global BA
// (slam/module/global_bundle_adjustment.h). ORB-SLAM's LoopClosing thread, except that this
// stage never writes the map (docs/slam.md "Threads"):
//
// - it detects on a copy of the map that the map's writer (local mapping) made after a keyframe
//   and handed over through a bounded slot (LoopClosingInput, capacity 1: while the stage is
//   busy, new keyframe ids accumulate at the writer and come with the next copy), with a
//   keyframe database of its own that it brings up to date with each copy (the writer's holds
//   every keyframe of the map, and a keyframe's BoW never changes, so adding the new keyframes
//   and erasing the culled ones gives the same database without copying its posting lists);
// - a detected loop goes back to the writer (LoopCorrectionWriter::CorrectLoop), which merges
//   and corrects it in the live map, where keyframes added since the copy exist too: the pose
//   graph moves them with the rest of the segment;
// - the writer captures global BA's job with the correction; this stage solves it (no map
//   access) and hands it back (LoopCorrectionWriter::ApplyGlobalBA), and the writer applies it,
//   moving keyframes and points added meanwhile with their spanning-tree ancestor / reference
//   keyframe; a job overtaken by a later loop or reset is dropped.
//
// Deterministic mode runs the same DetectAndCorrectLoops inline on the live map, with the writer
// called directly: the order of detections and corrections is the threaded stage's.
//
// Thread safety: DetectAndCorrectLoops on one thread at a time (the stage's own thread once
// Start() was called). Post/Stop/Idle from any thread. No lock is held while detecting, while
// waiting for the writer, or while solving.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "slam/bow/bow_database.h"
#include "slam/data/slam_map.h"
#include "slam/module/global_bundle_adjustment.h"
#include "slam/module/line_cloud_loop.h"
#include "slam/module/loop_detector.h"
#include "slam/system_options.h"
#include "slam/util/bounded_queue.h"
#include "slam/util/ids.h"
#include "slam/util/lock_timing.h"

namespace lcv::slam {

// What the writer did with a detected loop.
struct LoopCorrectionOutcome {
  bool closed = false;  // corrected (the corrector may reject a detection)
  // Captured right after the correction when global BA is on (threaded mode), to be solved by
  // the stage and applied by the writer.
  std::optional<GlobalBAJob> global_ba_job;
};

// The map's one writer as the loop-closing stage sees it (System: the mapping thread, or inline).
class LoopCorrectionWriter {
 public:
  virtual ~LoopCorrectionWriter() = default;
  // Merges segments if needed, corrects the loop in the live map, counts it, republishes the
  // snapshot. Called from the stage's thread; returns once the writer has done it (the stage
  // waits, tracking does not). generation: of the map the loop was detected in; a map reset
  // since makes the writer drop it.
  virtual LoopCorrectionOutcome CorrectLoop(const LoopDetection& loop, std::uint64_t generation) = 0;
  // The same for a loop closed against the server's line cloud (slam/module/line_cloud_loop.h).
  virtual LoopCorrectionOutcome CorrectLineCloudLoop(const LineCloudLoopDetection& loop,
                                                     std::uint64_t generation) = 0;
  // Hands a solved global BA job back (threaded mode); the writer applies it when it is not
  // stale. Does not wait.
  virtual void ApplyGlobalBA(GlobalBAJob job, double solve_ms, std::uint64_t generation) = 0;
};

// A copy of the map for detection, made by the writer after a keyframe.
struct LoopClosingInput {
  std::shared_ptr<const SlamMap> map;
  // The server keyframes' BoW (LocalMapper::server_database): constant once a line cloud is
  // loaded, shared, not copied. Null without a line cloud.
  std::shared_ptr<const BowDatabase> server_database;
  std::vector<Id> new_keyframe_ids;  // in insertion order, since the last input
  std::uint64_t generation = 0;      // of the map (increases at every reset / initialization)
};

// Brings `database` to the keyframes of `map`: erases those the map no longer has (culled,
// discarded, reset) and adds the new ones with their BoW vectors. What the writer's database
// holds, as a keyframe's BoW never changes once it is in the map.
void SyncDatabaseWithMap(const SlamMap& map, BowDatabase* database);

class LoopClosing {
 public:
  // writer: outlives this stage.
  LoopClosing(const SystemOptions& options, LoopCorrectionWriter* writer);
  ~LoopClosing();
  LoopClosing(const LoopClosing&) = delete;
  LoopClosing& operator=(const LoopClosing&) = delete;

  // Loop detection for the keyframes mapped since the last call and, on a loop, its
  // correction by the writer. map/database: the live map and the writer's database (inline), or
  // the input's copy and this stage's database brought up to date with it (thread);
  // generation: the map's, a new one restarts the detector (its consistency groups belong to the
  // old map). True when a loop was corrected.
  // server_database: the line cloud's server keyframes (null: none); with a registered map, each
  // keyframe is first tried against the line cloud (line-cloud loop), then as an ordinary loop.
  bool DetectAndCorrectLoops(const SlamMap& map, const BowDatabase& database,
                             const BowDatabase* server_database,
                             const std::vector<Id>& new_keyframe_ids, std::uint64_t generation,
                             std::optional<GlobalBAJob>* global_ba_job = nullptr);

  // Threaded mode: starts the stage's thread.
  void Start();
  // Global BA settings of the stage's jobs (iterations, Omega_vL), also for the inline mode.
  GlobalBAOptions GlobalBAOptionsFromSettings() const;
  // True when the slot is free (the writer copies the map only then).
  bool CanPost() const { return !inputs_.Full(); }
  // Hands an input over; false (nothing taken) when the slot is full. recorder: the caller's.
  bool Post(LoopClosingInput&& input, LockHoldRecorder* recorder = nullptr);
  // The input slot is empty and nothing is being detected, corrected or solved.
  bool Idle() const { return inputs_.Idle(); }
  // Waits until Idle().
  void WaitIdle() { inputs_.WaitIdle(); }
  // Finishes the input in the slot (and its global BA), then joins the thread.
  void Stop();

  // Hold times of the locks the stage's thread took (read after Stop()).
  const LockHoldRecorder& lock_recorder() const { return lock_recorder_; }
  // The nice value the stage's thread ran at (SystemOptions::background_nice applied) and the
  // error when the system refused it (empty: applied). Read after Stop().
  int thread_nice() const { return thread_nice_; }
  const std::string& thread_priority_error() const { return thread_priority_error_; }

 private:
  void Run();
  // The line-cloud loop for keyframe id (before the ordinary detection): detection on `map`,
  // correction by the writer. True when corrected.
  bool DetectLineCloudLoop(const SlamMap& map, const BowDatabase& server_database, Id id,
                           std::uint64_t generation, std::optional<GlobalBAJob>* global_ba_job);

  SystemOptions options_;
  LoopCorrectionWriter* writer_;
  // Threaded mode: the keyframe database of the latest input's map (SyncDatabaseWithMap).
  BowDatabase database_;
  LoopDetector loop_detector_{LoopDetectorOptions()};
  std::uint64_t detector_generation_ = 0;
  int keyframes_since_line_cloud_loop_ = 0;  // keyframes checked since the last line-cloud loop
  BoundedQueue<LoopClosingInput> inputs_{1};
  LockHoldRecorder lock_recorder_;
  int thread_nice_ = 0;
  std::string thread_priority_error_;
  std::thread thread_;
};

}  // namespace lcv::slam
