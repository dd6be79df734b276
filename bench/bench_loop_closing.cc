// Loop-closing benchmark (not run by ctest). For each loop sequence (one per camera model, from
// `lcv synth --scenario loop`), runs the engine twice on the client sequence, with loop closing
// and without (relocalization stays on in both, as `lcv slam --no-loop-closing`), and prints per
// run the loops detected / closed, the APE (Sim(3)-aligned RMSE, metres and % of the path
// length) and, with loop closing, the APE reduction. The target: the loop is detected
// and closed and the APE with loop closing is at least 30% lower than without.
//
// It also prints the drift at the revisit, which is what loop closing removes: the estimate is
// Sim(3)-aligned on the loop's start only (the first --start-fraction of the frames), and the
// revisit frames (ground truth within 4 m of a start frame, in the second half of the
// sequence) are compared with the ground truth under that alignment.
//
// Usage: bench_loop_closing [--vocabulary FILE] [--num-features N] [--threads] [--realtime]
//                           [--frames A:B:S] [--start-fraction F] [--json FILE] SCENE_DIR ...
//   SCENE_DIR  an `lcv synth --scenario loop` output folder (its client sequence is run), or any
//              dataset with ground truth whose trajectory returns to its start.
//   --vocabulary  BoW vocabulary (default: mapping::DefaultVocabularyPath()).
//   --threads  mapping and loop closing on their own threads (default: deterministic, inline).
//   --realtime feed the frames at the sequence's rate (with --threads: as a live camera).
//   --json     also write the results as JSON.
// Progress goes to stderr, the table to stdout.
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
  std::string frames = ":";
  double start_fraction = 0.1;
};

struct RevisitFrames {
  double start_end_time = 0.0;  // the start segment: timestamps <= this
  std::vector<double> times;    // timestamps of the revisit frames
};

// From the ground truth alone: the start segment and the later frames that come back to it.
RevisitFrames FindRevisit(const bench::LoadedSequence& sequence, double start_fraction) {
  RevisitFrames revisit;
  const auto& gt = sequence.ground_truth.poses;
  if (gt.empty()) return revisit;
  const size_t start_count =
      std::clamp<size_t>(static_cast<size_t>(start_fraction * gt.size()), 3, gt.size());
  revisit.start_end_time = gt[start_count - 1].timestamp;
  for (size_t i = std::max(start_count, gt.size() / 2); i < gt.size(); ++i) {
    for (size_t j = 0; j < start_count; ++j) {
      if ((gt[i].cam_from_world.Center() - gt[j].cam_from_world.Center()).norm() < 4.0) {
        revisit.times.push_back(gt[i].timestamp);
        break;
      }
    }
  }
  return revisit;
}

struct RunSummary {
  bench::SystemRun run;
  bench::ApeSummary ape;
  std::optional<bench::AlignedError> revisit_error;  // under the start-segment alignment
};

RunSummary RunOnce(const bench::LoadedSequence& sequence, const BenchOptions& bench_options,
                   const std::shared_ptr<const slam::Vocabulary>& vocabulary, bool loop_closing,
                   const RevisitFrames& revisit, const std::string& label) {
  slam::SystemOptions options =
      bench::BenchSystemOptions(sequence.camera, bench_options.common, vocabulary);
  options.loop_closing.enabled = loop_closing;
  RunSummary summary;
  summary.run = bench::RunSystem(sequence, options, nullptr, nullptr, false, label,
                                 bench_options.common.realtime);
  summary.ape = bench::Sim3Ape(sequence, summary.run.trajectory);
  if (!revisit.times.empty()) {
    const auto aligned =
        bench::AlignOnPrefix(sequence, summary.run.trajectory, revisit.start_end_time);
    if (aligned) {
      summary.revisit_error = bench::ErrorUnderAlignment(
          sequence, summary.run.trajectory, *aligned, revisit.times.front(), revisit.times.back());
    }
  }
  return summary;
}

nlohmann::json RunJson(const RunSummary& s, const bench::LoadedSequence& sequence) {
  nlohmann::json j;
  j["tracked"] = bench::CountTracked(s.run.results);
  j["frames_fed"] = s.run.results.size();
  j["keyframes"] = s.run.keyframes;
  j["landmarks"] = s.run.landmarks;
  j["initializations"] = s.run.initializations;
  j["loops_detected"] = s.run.stats.loops_detected;
  j["loops_closed"] = s.run.stats.loops_closed;
  j["relocalizations"] = s.run.stats.relocalizations;
  j["pose_graph_ms"] = s.run.stats.pose_graph_ms;
  j["global_ba_runs"] = s.run.stats.global_ba_runs;
  j["global_ba_ms"] = s.run.stats.global_ba_ms;
  j["wall_s"] = s.run.wall_s;
  nlohmann::json loops = nlohmann::json::array();
  for (const slam::LoopEvent& e : s.run.stats.loops) {
    loops.push_back({{"query_keyframe", e.query_keyframe_id},
                     {"match_keyframe", e.match_keyframe_id},
                     {"timestamp", e.timestamp},
                     {"closed", e.closed},
                     {"matches", e.num_matches}});
  }
  j["loops"] = loops;
  if (s.ape.problem) {
    j["ape_problem"] = *s.ape.problem;
  } else {
    j["ape_rmse_m"] = s.ape.rmse_m;
    j["ape_max_m"] = s.ape.max_m;
    j["ape_percent_of_path"] = s.ape.percent_of_path;
    j["ape_matched"] = s.ape.matched;
  }
  if (s.revisit_error) {
    j["revisit_rmse_m"] = s.revisit_error->rmse_m;
    j["revisit_max_m"] = s.revisit_error->max_m;
    j["revisit_frames_tracked"] = s.revisit_error->count;
  }
  j["path_length_m"] = sequence.path_length_m;
  return j;
}

void PrintRun(const char* name, const RunSummary& s) {
  std::printf("  %-16s tracked %4d/%-4zu  kf %3d  loops %d/%d  reloc %d  ", name,
              bench::CountTracked(s.run.results), s.run.results.size(), s.run.keyframes,
              s.run.stats.loops_detected, s.run.stats.loops_closed, s.run.stats.relocalizations);
  if (s.ape.problem) {
    std::printf("APE: %s", s.ape.problem->c_str());
  } else {
    std::printf("APE %.3f m (%.2f%%)", s.ape.rmse_m, s.ape.percent_of_path);
  }
  if (s.revisit_error && s.revisit_error->count > 0) {
    std::printf("  revisit %.2f m (max %.2f, %d frames)", s.revisit_error->rmse_m,
                s.revisit_error->max_m, s.revisit_error->count);
  }
  std::printf("  wall %.1f s\n", s.run.wall_s);
}

nlohmann::json RunDataset(const std::string& path, const BenchOptions& options,
                          const std::shared_ptr<const slam::Vocabulary>& vocabulary) {
  const bench::LoadedSequence sequence = bench::LoadSequence(path, "client", options.frames);
  const RevisitFrames revisit = FindRevisit(sequence, options.start_fraction);
  const char* model = slam::CameraModelName(sequence.camera.model);
  const RunSummary off = RunOnce(sequence, options, vocabulary, false, revisit,
                                 std::string(model) + " no loop closing");
  const RunSummary on =
      RunOnce(sequence, options, vocabulary, true, revisit, std::string(model) + " loop closing");

  std::printf("%s (%s, %dx%d, %zu frames, path %.1f m, %zu revisit frames)\n",
              sequence.path.c_str(), model, sequence.camera.cols, sequence.camera.rows,
              sequence.images.size(), sequence.path_length_m, revisit.times.size());
  PrintRun("no loop closing", off);
  PrintRun("loop closing", on);
  for (const slam::LoopEvent& e : on.run.stats.loops) {
    std::printf("    loop at t=%.2f s: keyframe %llu -> %llu, %d matches, %s\n", e.timestamp,
                static_cast<unsigned long long>(e.query_keyframe_id),
                static_cast<unsigned long long>(e.match_keyframe_id), e.num_matches,
                e.closed ? "closed" : "rejected");
  }
  nlohmann::json j;
  j["dataset"] = sequence.path;
  j["camera_model"] = model;
  j["cols"] = sequence.camera.cols;
  j["rows"] = sequence.camera.rows;
  j["frames"] = sequence.images.size();
  j["revisit_frames"] = revisit.times.size();
  j["no_loop_closing"] = RunJson(off, sequence);
  j["loop_closing"] = RunJson(on, sequence);
  if (!off.ape.problem && !on.ape.problem && off.ape.rmse_m > 0) {
    const double reduction = 100.0 * (1.0 - on.ape.rmse_m / off.ape.rmse_m);
    j["ape_reduction_percent"] = reduction;
    std::printf("  APE reduction %.1f%% (target >= 30%%, loop closed: %s)\n", reduction,
                on.run.stats.loops_closed > 0 ? "yes" : "NO");
  }
  std::fflush(stdout);
  return j;
}

}  // namespace

int main(int argc, char** argv) {
  BenchOptions options;
  std::vector<std::string> datasets;
  const int status = bench::ParseBenchArguments(
      argc, argv,
      "usage: bench_loop_closing [--vocabulary FILE] [--num-features N] [--threads] "
      "[--realtime] [--frames A:B:S] [--start-fraction F] [--json FILE] SCENE_DIR ...",
      "bench_loop_closing: give at least one loop scene folder (lcv synth --scenario loop ...)",
      [&](const std::string& arg, int* i) {
        if (arg == "--frames") {
          options.frames = bench::OptionValue(argc, argv, i);
        } else if (arg == "--start-fraction") {
          options.start_fraction = std::atof(bench::OptionValue(argc, argv, i).c_str());
        } else {
          return false;
        }
        return true;
      },
      &options.common, &datasets);
  if (status >= 0) return status;
  if (!(options.start_fraction > 0.0 && options.start_fraction < 0.5)) {
    std::fprintf(stderr, "--start-fraction must be in (0, 0.5)\n");
    return 2;
  }
  return bench::RunEachDataset(
      "bench_loop_closing", datasets, options.common,
      [&](const std::string& path, const std::shared_ptr<const slam::Vocabulary>& vocabulary) {
        return RunDataset(path, options, vocabulary);
      });
}
