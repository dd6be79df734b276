// Monocular initialization benchmark (not run by ctest; issue 15): starts a fresh System at
// many start frames of each sequence and prints, per start, how many frames it took to
// initialize, whether the map was later reset (re-initialized: a wrong initialization counts as
// a failure), the share of the fed frames that carry a pose in the final trajectory, and the
// APE after Sim(3) alignment of the first 50 tracked frames; then the summary per dataset and
// over all datasets (median / max frames to initialize, resets, never initialized).
//
// Usage: bench_initialization [--step N] [--starts A:B] [--run-frames N] [--min-frames N]
//                             [--ape-frames N]
//                             [--sequence NAME] [--threads] [--vocabulary FILE] [--json FILE]
//                             [--verbose] DATASET ...
//   DATASET       any folder OpenDataset reads; for an `lcv synth` scene its client sequence
//                 (--sequence map for the other one). E.g. ../shared/data/kitti00 and
//                 `lcv synth --scenario tracking|loop --camera MODEL --frames 100 --seed 1`.
//   --step        start frames 0, N, 2N, ... (default 10)
//   --starts A:B  only start frames A, A+N, ... up to B
//   --run-frames  frames fed per start (default 60: initialization plus >= 50 tracked)
//   --min-frames  starts with fewer frames left are skipped (default 30)
//   --ape-frames  the APE is over the first N poses of the trajectory (default 50)
// Frames to initialize: index of the first tracked frame minus the start frame (the reference
// frame of the initialization is the start frame at best, so 1 is the least possible).
// Targets (issue 15): median <= 5 and max <= 10 frames to initialize, no reset.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/slam_bench_common.h"

namespace {

using namespace lcv;

struct BenchOptions {
  bench::CommonOptions common;
  std::string sequence = "client";
  int step = 10;
  int first_start = 0;
  int last_start = -1;  // -1: as far as --min-frames allows
  int run_frames = 60;
  int min_frames = 30;
  int ape_frames = 50;
  bool verbose = false;
};

struct StartResult {
  int start = 0;
  int fed = 0;
  int frames_to_initialize = -1;  // -1: never initialized
  bool reset = false;             // re-initialized after the first initialization
  int initializations = 0;
  int lost = 0;                   // lost frames after the first initialization
  int posed = 0;                  // poses in the final trajectory
  double ape_m = -1.0;            // first ape_frames poses, Sim(3)-aligned
  int ape_poses = 0;
};

struct Summary {
  int starts = 0, never = 0, resets = 0;
  double median = 0.0;
  int max = 0;
  double median_ape_m = 0.0, max_ape_m = 0.0;
  int fed = 0, posed = 0;
};

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// A start that never initialized counts as the frames it was fed (plus one) in the median and
// the maximum: it is a failure, and must not make the summary look better.
Summary Summarize(const std::vector<StartResult>& results) {
  Summary s;
  std::vector<double> frames, apes;
  for (const StartResult& r : results) {
    ++s.starts;
    s.resets += r.reset;
    s.fed += r.fed;
    s.posed += r.posed;
    const int f = r.frames_to_initialize >= 0 ? r.frames_to_initialize : r.fed + 1;
    if (r.frames_to_initialize < 0) ++s.never;
    frames.push_back(f);
    s.max = std::max(s.max, f);
    if (r.ape_m >= 0.0) {
      apes.push_back(r.ape_m);
      s.max_ape_m = std::max(s.max_ape_m, r.ape_m);
    }
  }
  s.median = Median(frames);
  s.median_ape_m = Median(apes);
  return s;
}

void PrintSummary(const char* label, const Summary& s) {
  std::printf("%s: %d starts, frames to initialize median %.1f max %d, never %d, resets %d, "
              "posed %d/%d frames (%.1f%%), APE first poses median %.3f m max %.3f m\n",
              label, s.starts, s.median, s.max, s.never, s.resets, s.posed, s.fed,
              s.fed > 0 ? 100.0 * s.posed / s.fed : 0.0, s.median_ape_m, s.max_ape_m);
}

StartResult RunStart(const bench::LoadedSequence& full, int start, const BenchOptions& options,
                     const slam::SystemOptions& system_options) {
  const int end = std::min(static_cast<int>(full.images.size()), start + options.run_frames);
  bench::LoadedSequence part;
  part.path = full.path;
  part.camera = full.camera;
  part.ground_truth = full.ground_truth;
  part.images.assign(full.images.begin() + start, full.images.begin() + end);
  part.timestamps.assign(full.timestamps.begin() + start, full.timestamps.begin() + end);
  const bench::SystemRun run =
      bench::RunSystem(part, system_options, nullptr, nullptr, false, "", false);

  StartResult r;
  r.start = start;
  r.fed = end - start;
  r.initializations = run.initializations;
  for (size_t k = 0; k < run.results.size(); ++k) {
    const slam::TrackingState state = run.results[k].state;
    if (r.frames_to_initialize < 0) {
      if (state == slam::TrackingState::kTracking) r.frames_to_initialize = static_cast<int>(k);
      continue;
    }
    if (state == slam::TrackingState::kLost) ++r.lost;
    if (state == slam::TrackingState::kInitializing) r.reset = true;
  }
  r.reset = r.reset || run.initializations > 1;
  r.posed = static_cast<int>(run.trajectory.size());
  if (options.verbose) {
    for (size_t k = 0; k < run.results.size() && k < 25; ++k) {
      const slam::FrameResult& fr = run.results[k];
      std::fprintf(stderr, "    frame %d: %s, %d keypoints, %d matches%s\n",
                   start + static_cast<int>(k), slam::TrackingStateName(fr.state),
                   fr.num_keypoints, fr.num_matches, fr.is_keyframe ? ", keyframe" : "");
    }
  }
  std::vector<slam::TimedPose> first = run.trajectory;
  std::sort(first.begin(), first.end(),
            [](const auto& a, const auto& b) { return a.timestamp < b.timestamp; });
  if (static_cast<int>(first.size()) > options.ape_frames) first.resize(options.ape_frames);
  if (first.size() >= 3) {
    const bench::ApeSummary ape = bench::Sim3Ape(full, first);
    if (!ape.problem) {
      r.ape_m = ape.rmse_m;
      r.ape_poses = ape.matched;
    }
  }
  return r;
}

nlohmann::json RunDataset(const std::string& path, const BenchOptions& options,
                          const std::shared_ptr<const slam::Vocabulary>& vocabulary,
                          std::vector<StartResult>* all) {
  const bench::LoadedSequence sequence = bench::LoadSequence(path, options.sequence);
  const int n = static_cast<int>(sequence.images.size());
  const slam::SystemOptions system_options =
      bench::BenchSystemOptions(sequence.camera, options.common, vocabulary);
  std::printf("%s (%s, %dx%d, %d frames)\n", sequence.path.c_str(),
              slam::CameraModelName(sequence.camera.model), sequence.camera.cols,
              sequence.camera.rows, n);
  std::printf("  start  frames-to-init  reset  lost  posed      APE(first %d, Sim3)\n",
              options.ape_frames);
  std::vector<StartResult> results;
  nlohmann::json starts = nlohmann::json::array();
  for (int start = options.first_start; start + options.min_frames <= n; start += options.step) {
    if (options.last_start >= 0 && start > options.last_start) break;
    const StartResult r = RunStart(sequence, start, options, system_options);
    results.push_back(r);
    all->push_back(r);
    std::printf("  %5d  %14s  %5s  %4d  %3d/%-3d  ", r.start,
                r.frames_to_initialize >= 0 ? std::to_string(r.frames_to_initialize).c_str()
                                            : "never",
                r.reset ? "RESET" : "no", r.lost, r.posed, r.fed);
    if (r.ape_m >= 0.0) {
      std::printf("%.3f m (%d poses)\n", r.ape_m, r.ape_poses);
    } else {
      std::printf("-\n");
    }
    std::fflush(stdout);
    nlohmann::json j;
    j["start"] = r.start;
    j["fed"] = r.fed;
    j["frames_to_initialize"] = r.frames_to_initialize;
    j["reset"] = r.reset;
    j["initializations"] = r.initializations;
    j["lost"] = r.lost;
    j["posed"] = r.posed;
    if (r.ape_m >= 0.0) j["ape_first_m"] = r.ape_m;
    starts.push_back(j);
  }
  const Summary s = Summarize(results);
  PrintSummary("  summary", s);
  nlohmann::json out;
  out["dataset"] = sequence.path;
  out["camera_model"] = slam::CameraModelName(sequence.camera.model);
  out["frames"] = n;
  out["starts"] = starts;
  out["median_frames_to_initialize"] = s.median;
  out["max_frames_to_initialize"] = s.max;
  out["never_initialized"] = s.never;
  out["resets"] = s.resets;
  out["posed"] = s.posed;
  out["fed"] = s.fed;
  out["median_ape_first_m"] = s.median_ape_m;
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  BenchOptions options;
  std::vector<std::string> datasets;
  const int status = bench::ParseBenchArguments(
      argc, argv,
      "usage: bench_initialization [--step N] [--starts A:B] [--run-frames N] [--min-frames N] "
      "[--ape-frames N] [--sequence NAME] [--vocabulary FILE] [--num-features N] [--threads] "
      "[--json FILE] [--verbose] DATASET ...",
      "bench_initialization: give at least one dataset (e.g. ../shared/data/kitti00)",
      [&](const std::string& arg, int* i) {
        if (arg == "--step") {
          options.step = std::max(1, std::atoi(bench::OptionValue(argc, argv, i).c_str()));
        } else if (arg == "--starts") {
          // A:B, the first and last start frame.
          const std::string range = bench::OptionValue(argc, argv, i);
          const size_t colon = range.find(':');
          options.first_start = std::max(0, std::atoi(range.substr(0, colon).c_str()));
          if (colon != std::string::npos && colon + 1 < range.size()) {
            options.last_start = std::atoi(range.substr(colon + 1).c_str());
          }
        } else if (arg == "--run-frames") {
          options.run_frames = std::max(2, std::atoi(bench::OptionValue(argc, argv, i).c_str()));
        } else if (arg == "--min-frames") {
          options.min_frames = std::max(2, std::atoi(bench::OptionValue(argc, argv, i).c_str()));
        } else if (arg == "--ape-frames") {
          options.ape_frames = std::max(3, std::atoi(bench::OptionValue(argc, argv, i).c_str()));
        } else if (arg == "--sequence") {
          options.sequence = bench::OptionValue(argc, argv, i);
        } else if (arg == "--verbose") {
          options.verbose = true;
        } else {
          return false;
        }
        return true;
      },
      &options.common, &datasets);
  if (status >= 0) return status;
  std::vector<StartResult> all;
  const int run_status = bench::RunEachDataset(
      "bench_initialization", datasets, options.common,
      [&](const std::string& path, const std::shared_ptr<const slam::Vocabulary>& vocabulary) {
        return RunDataset(path, options, vocabulary, &all);
      });
  PrintSummary("all datasets", Summarize(all));
  return run_status;
}
