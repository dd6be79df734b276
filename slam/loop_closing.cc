#include "slam/loop_closing.h"

#include <chrono>
#include <utility>

#include "slam/util/thread_priority.h"

namespace lcv::slam {

LoopClosing::LoopClosing(const SystemOptions& options, LoopCorrectionWriter* writer)
    : options_(options), writer_(writer) {}

LoopClosing::~LoopClosing() { Stop(); }

bool LoopClosing::DetectAndCorrectLoops(const SlamMap& map, const BowDatabase& database,
                                        const BowDatabase* server_database,
                                        const std::vector<Id>& new_keyframe_ids,
                                        std::uint64_t generation,
                                        std::optional<GlobalBAJob>* global_ba_job) {
  if (generation != detector_generation_) {
    loop_detector_.Reset();
    detector_generation_ = generation;
  }
  bool corrected = false;
  for (const Id id : new_keyframe_ids) {
    if (corrected || map.FindKeyframe(id) == nullptr) continue;
    if (server_database != nullptr && DetectLineCloudLoop(map, *server_database, id, generation,
                                                          global_ba_job)) {
      corrected = true;
      continue;
    }
    std::optional<LoopDetection> loop =
        loop_detector_.Detect(map, database, id, options_.seed + id);
    if (!loop) continue;
    // Merge, correction, counting and republishing are the writer's, on the live map
    // (System::Impl::CorrectDetectedLoop, slam/map_writer.cc).
    LoopCorrectionOutcome outcome = writer_->CorrectLoop(*loop, generation);
    if (outcome.closed) {
      corrected = true;
      if (global_ba_job != nullptr) *global_ba_job = std::move(outcome.global_ba_job);
    }
  }
  return corrected;
}

bool LoopClosing::DetectLineCloudLoop(const SlamMap& map, const BowDatabase& server_database,
                                      Id id, std::uint64_t generation,
                                      std::optional<GlobalBAJob>* global_ba_job) {
  const LineCloudSettings& settings = options_.line_cloud;
  if (!settings.close_loops || !map.ActiveSegmentRegistered()) return false;
  if (++keyframes_since_line_cloud_loop_ <= settings.loop.min_keyframes_between_loops) {
    return false;
  }
  std::optional<LineCloudLoopDetection> loop = slam::DetectLineCloudLoop(
      options_.vocabulary.get(), server_database, id, settings.loop, options_.seed + id, map);
  if (!loop) return false;
  LoopCorrectionOutcome outcome = writer_->CorrectLineCloudLoop(*loop, generation);
  if (!outcome.closed) return false;
  keyframes_since_line_cloud_loop_ = 0;
  if (global_ba_job != nullptr) *global_ba_job = std::move(outcome.global_ba_job);
  return true;
}

GlobalBAOptions LoopClosing::GlobalBAOptionsFromSettings() const {
  GlobalBAOptions ba_options;
  ba_options.max_iterations = options_.loop_closing.global_ba_iterations;
  ba_options.derived_virtual_information = options_.line_cloud.derived_virtual_information;
  return ba_options;
}

void LoopClosing::Start() {
  if (thread_.joinable()) return;
  thread_ = std::thread([this] { Run(); });
}

bool LoopClosing::Post(LoopClosingInput&& input, LockHoldRecorder* recorder) {
  return inputs_.TryPush(std::move(input), recorder);
}

void LoopClosing::Stop() {
  if (!thread_.joinable()) return;
  inputs_.WaitIdle();
  inputs_.Stop();
  thread_.join();
}

void SyncDatabaseWithMap(const SlamMap& map, BowDatabase* database) {
  for (const Id id : database->Ids()) {
    if (map.FindKeyframe(id) == nullptr) database->Erase(id);
  }
  for (const auto& [id, keyframe] : map.keyframes()) {
    if (!database->Contains(id)) database->Add(id, keyframe.bow);
  }
}

void LoopClosing::Run() {
  // Below tracking's priority, as the map's writer (SystemOptions::background_nice); global BA's
  // solve, the longest job of the engine, runs here.
  if (!LowerCurrentThreadPriority(options_.background_nice, &thread_priority_error_)) {
    thread_priority_error_ = "loop-closing thread: " + thread_priority_error_;
  }
  thread_nice_ = CurrentThreadNice();
  for (;;) {
    std::optional<LoopClosingInput> input = inputs_.Pop(&lock_recorder_);
    if (!input) return;
    std::optional<GlobalBAJob> job;
    SyncDatabaseWithMap(*input->map, &database_);
    const bool corrected =
        DetectAndCorrectLoops(*input->map, database_, input->server_database.get(),
                              input->new_keyframe_ids, input->generation, &job);
    // The copy is not needed any more; release it before the (long) solve.
    input.reset();
    if (corrected && job) {
      const auto start = std::chrono::steady_clock::now();
      SolveGlobalBA(GlobalBAOptionsFromSettings(), &*job);
      const double solve_ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
              .count();
      writer_->ApplyGlobalBA(std::move(*job), solve_ms, detector_generation_);
    }
    inputs_.Done(&lock_recorder_);
  }
}

}  // namespace lcv::slam
