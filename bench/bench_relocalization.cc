// Relocalization benchmark (not run by ctest). Runs the engine over a sequence in which frames
// [a, a + n) are interrupted, either replaced by black images (a covered lens, the default) or
// not fed at all (--skip: a dropped stream), and reports how many frames after the
// interruption's end tracking resumed, whether by relocalization (FrameResult::relocalized)
// and without a new map (initializations stay 1), and the APE of the frames after it. The
// issue's target: tracking resumes by relocalization within 10 frames of the interruption's end.
//
// APE: the whole trajectory is Sim(3)-aligned once; "after" is the RMSE of the frames after the
// interruption under that same alignment, so a relocalized pose that does not agree with the map
// built before the gap shows up as a large error.
//
// Usage: bench_relocalization [--vocabulary FILE] [--sequence NAME] [--gap-start A]
//                             [--gap-frames N] [--skip] [--num-features N] [--threads] [--realtime]
//                             [--frames A:B:S] [--json FILE] [--verbose] DATASET ...
//   DATASET      a dataset with ground truth; for `lcv synth` scene folders the --sequence
//                (default client).
//   --gap-start  first interrupted frame (default: the middle of the sequence).
//   --gap-frames interrupted frames (default: one second, the camera's fps, 10 if unknown).
//   --verbose    per-frame tracking state around the interruption on stderr.
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/slam_bench_common.h"

namespace {

using namespace lcv;

struct BenchOptions {
  bench::CommonOptions common;
  std::string sequence = "client";
  int gap_start = -1;   // -1: the middle
  int gap_frames = -1;  // -1: one second
  bool skip = false;
  std::string frames = ":";
  bool verbose = false;  // per-frame state around the interruption on stderr
};

nlohmann::json RunDataset(const std::string& path, const BenchOptions& options,
                          const std::shared_ptr<const slam::Vocabulary>& vocabulary) {
  const bench::LoadedSequence sequence =
      bench::LoadSequence(path, options.sequence, options.frames);
  const int num_frames = static_cast<int>(sequence.images.size());
  const int fps = std::max(1, static_cast<int>(std::lround(
                                  sequence.camera.fps > 0 ? sequence.camera.fps : 10.0)));
  const int gap_begin = options.gap_start >= 0 ? options.gap_start : num_frames / 2;
  const int gap_length = options.gap_frames >= 0 ? options.gap_frames : fps;
  const int gap_end = std::min(num_frames, gap_begin + gap_length);
  if (gap_begin >= num_frames) throw std::runtime_error("--gap-start beyond the sequence");
  const char* model = slam::CameraModelName(sequence.camera.model);

  slam::SystemOptions system_options =
      bench::BenchSystemOptions(sequence.camera, options.common, vocabulary);
  const auto action = [&](int i) {
    if (i < gap_begin || i >= gap_end) return bench::FrameAction::kFeed;
    return options.skip ? bench::FrameAction::kSkip : bench::FrameAction::kBlank;
  };
  const bench::SystemRun run =
      bench::RunSystem(sequence, system_options, nullptr, action, false, model, options.common.realtime);

  // The first tracked frame at or after the interruption's end, and whether a relocalization
  // happened between the interruption's start and it.
  int resumed = -1;
  bool relocalized = false;
  int lost_before_gap = 0;  // frames lost before the interruption (after initialization)
  bool initialized = false;
  for (size_t k = 0; k < run.results.size(); ++k) {
    const int i = run.frame_index[k];
    const slam::FrameResult& r = run.results[k];
    if (i < gap_begin) {
      if (r.state == slam::TrackingState::kTracking) initialized = true;
      if (initialized && r.state != slam::TrackingState::kTracking) ++lost_before_gap;
      continue;
    }
    relocalized = relocalized || r.relocalized;
    if (i >= gap_end && r.state == slam::TrackingState::kTracking) {
      resumed = i;
      break;
    }
  }
  if (options.verbose) {
    for (size_t k = 0; k < run.results.size(); ++k) {
      const int i = run.frame_index[k];
      if (i < gap_begin - 3 || i > std::max(resumed, gap_end) + 3) continue;
      const slam::FrameResult& r = run.results[k];
      std::fprintf(stderr, "  frame %d: %s, %d keypoints, %d matches%s%s%s\n", i,
                   slam::TrackingStateName(r.state), r.num_keypoints, r.num_matches,
                   r.is_keyframe ? ", keyframe" : "", r.relocalized ? ", relocalized" : "",
                   r.two_view ? ", two-view" : "");
    }
  }
  // A resumption on a wrong pose shows as tracking lost again soon after.
  int tracked_after = 0, frames_after = 0, lost_again = -1;
  for (size_t k = 0; k < run.results.size(); ++k) {
    if (run.frame_index[k] < gap_end) continue;
    ++frames_after;
    if (run.results[k].state == slam::TrackingState::kTracking) {
      ++tracked_after;
    } else if (resumed >= 0 && run.frame_index[k] > resumed && lost_again < 0) {
      lost_again = run.frame_index[k];
    }
  }
  const bench::ApeSummary ape = bench::Sim3Ape(sequence, run.trajectory);
  std::optional<bench::AlignedError> before, after;
  if (!ape.problem && gap_end < num_frames) {
    before = bench::ErrorUnderAlignment(sequence, run.trajectory, ape.gt_from_est, -1e300,
                                        sequence.timestamps[std::max(0, gap_begin - 1)]);
    after = bench::ErrorUnderAlignment(sequence, run.trajectory, ape.gt_from_est,
                                       sequence.timestamps[gap_end], 1e300);
  }

  std::printf("%s (%s, %dx%d, %d frames, path %.1f m)\n", sequence.path.c_str(), model,
              sequence.camera.cols, sequence.camera.rows, num_frames, sequence.path_length_m);
  std::printf("  interruption: frames [%d, %d) %s; lost before it %d\n", gap_begin, gap_end,
              options.skip ? "skipped" : "black", lost_before_gap);
  if (resumed >= 0) {
    std::printf("  resumed at frame %d = %d frames after the interruption, %s; "
                "initializations %d, relocalizations %d\n",
                resumed, resumed - gap_end, relocalized ? "relocalized" : "NOT by relocalization",
                run.initializations, run.stats.relocalizations);
  } else {
    std::printf("  tracking did NOT resume (initializations %d, relocalizations %d)\n",
                run.initializations, run.stats.relocalizations);
  }
  if (run.stats.maps_kept > 0) {
    std::printf("  lost maps kept %d, merged back by a loop %d\n", run.stats.maps_kept,
                run.stats.maps_merged);
  }
  std::printf("  tracked after the interruption %d/%d", tracked_after, frames_after);
  if (lost_again >= 0) std::printf("; LOST AGAIN at frame %d", lost_again);
  std::printf("\n");
  if (ape.problem) {
    std::printf("  APE: %s\n", ape.problem->c_str());
  } else {
    std::printf("  APE (Sim3, all) %.3f m (%.2f%% of the path)", ape.rmse_m, ape.percent_of_path);
    if (before && after) {
      std::printf("; same alignment: before %.3f m (%d), after %.3f m (%d poses)", before->rmse_m,
                  before->count, after->rmse_m, after->count);
    }
    std::printf("; wall %.1f s\n", run.wall_s);
  }
  std::fflush(stdout);

  nlohmann::json j;
  j["dataset"] = sequence.path;
  j["camera_model"] = model;
  j["frames"] = num_frames;
  j["gap_begin"] = gap_begin;
  j["gap_end"] = gap_end;
  j["gap_kind"] = options.skip ? "skip" : "black";
  j["resumed_frame"] = resumed;
  j["frames_to_resume"] = resumed >= 0 ? resumed - gap_end : -1;
  j["relocalized"] = relocalized;
  j["initializations"] = run.initializations;
  j["relocalizations"] = run.stats.relocalizations;
  j["maps_kept"] = run.stats.maps_kept;
  j["maps_merged"] = run.stats.maps_merged;
  j["lost_before_gap"] = lost_before_gap;
  j["tracked_after"] = tracked_after;
  j["lost_again_frame"] = lost_again;
  j["frames_after"] = frames_after;
  j["wall_s"] = run.wall_s;
  if (!ape.problem) {
    j["ape_rmse_m"] = ape.rmse_m;
    j["ape_percent_of_path"] = ape.percent_of_path;
    if (before && after) {
      j["ape_before_m"] = before->rmse_m;
      j["ape_after_m"] = after->rmse_m;
      j["poses_after"] = after->count;
    }
  } else {
    j["ape_problem"] = *ape.problem;
  }
  return j;
}

}  // namespace

int main(int argc, char** argv) {
  BenchOptions options;
  std::vector<std::string> datasets;
  const int status = bench::ParseBenchArguments(
      argc, argv,
      "usage: bench_relocalization [--vocabulary FILE] [--sequence NAME] [--gap-start A] "
      "[--gap-frames N] [--skip] [--num-features N] [--threads] [--realtime] [--frames A:B:S] "
      "[--json FILE] [--verbose] DATASET ...",
      "bench_relocalization: give at least one dataset",
      [&](const std::string& arg, int* i) {
        if (arg == "--sequence") {
          options.sequence = bench::OptionValue(argc, argv, i);
        } else if (arg == "--gap-start") {
          options.gap_start = std::atoi(bench::OptionValue(argc, argv, i).c_str());
        } else if (arg == "--gap-frames") {
          options.gap_frames = std::atoi(bench::OptionValue(argc, argv, i).c_str());
        } else if (arg == "--skip") {
          options.skip = true;
        } else if (arg == "--frames") {
          options.frames = bench::OptionValue(argc, argv, i);
        } else if (arg == "--verbose") {
          options.verbose = true;
        } else {
          return false;
        }
        return true;
      },
      &options.common, &datasets);
  if (status >= 0) return status;
  return bench::RunEachDataset(
      "bench_relocalization", datasets, options.common,
      [&](const std::string& path, const std::shared_ptr<const slam::Vocabulary>& vocabulary) {
        return RunDataset(path, options, vocabulary);
      });
}
