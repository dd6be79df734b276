// 2D point - 3D line matching (slam/match/line_projection_matcher.h): recall, precision and time
// per frame over a sweep of the discretization step and the search radius, for the three camera
// models at 640x360, on the synthetic scene of tests/slam/match/line_match_scene.h (~1500 lines
// whose intervals come from LineVisibleInterval over nearby server keyframes, ~1100 keypoints of
// which ~300 clutter, ORB-like look-alike descriptors). The frame is matched from a pose 2 cm and
// ~0.2 degrees off the truth (a constant-velocity prediction's error).
//
// Recall: correct matches / keypoints of hidden points; precision: correct / all matches.
// Time: median and p90 over seeds x repetitions of one MatchLinesByProjection call (ms), as
// thread CPU time (the machine is shared) and wall time.
// Usage: bench_line_matching [--reps N] [--seeds N] [--lines N] [--pose-error-scale X]
//                            [--camera perspective|fisheye|equirectangular]
//                            [--defaults-only | --only step|cell|descriptor]
// --pose-error-scale multiplies the pose error (2 cm, ~0.2 degrees at 1).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "bench/thread_cpu_clock.h"
#include "slam/match/line_projection_matcher.h"
#include "tests/slam/match/line_match_scene.h"

namespace {

using namespace lcv::slam;
using lcv::bench::ThreadCpuMs;

struct Row {
  double recall = 0, precision = 0, median_ms = 0, p90_ms = 0, cpu_median_ms = 0, cpu_p90_ms = 0,
         samples_per_line = 0, projections_per_line = 0, hits_per_line = 0;
};

double Percentile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5))];
}

Row Run(const std::vector<testing::LineScene>& scenes, const LineMatchOptions& options, int reps,
        double pose_error_scale) {
  Vector6d delta;
  delta << 0.02, -0.01, 0.005, 0.002, -0.003, 0.001;
  delta *= pose_error_scale;
  Row row;
  std::vector<double> times_ms, cpu_ms;
  long correct = 0, wrong = 0, findable = 0, samples = 0, projections = 0, hits = 0, lines = 0;
  LineMatchScratch scratch;
  for (const testing::LineScene& scene : scenes) {
    const Rigid3d pose = Rigid3d::Exp(delta) * scene.cam_from_world;
    Frame frame = testing::MakeLineSceneFrame(scene);
    for (int r = 0; r < reps; ++r) {
      frame.ResetMatches();
      const double cpu_start = ThreadCpuMs();
      const auto start = std::chrono::steady_clock::now();
      MatchLinesByProjection(scene.lines, pose, options, &frame, &scratch);
      const auto stop = std::chrono::steady_clock::now();
      cpu_ms.push_back(ThreadCpuMs() - cpu_start);
      times_ms.push_back(std::chrono::duration<double, std::milli>(stop - start).count());
    }
    const testing::LineMatchScore score = testing::ScoreLineMatches(scene, frame);
    correct += score.correct;
    wrong += score.wrong;
    findable += score.findable;
    samples += scratch.num_samples;
    projections += scratch.num_projections;
    hits += scratch.num_window_hits;
    lines += scene.lines.size();
  }
  row.recall = findable > 0 ? double(correct) / findable : 0.0;
  row.precision = correct + wrong > 0 ? double(correct) / (correct + wrong) : 1.0;
  row.median_ms = Percentile(times_ms, 0.5);
  row.p90_ms = Percentile(times_ms, 0.9);
  row.cpu_median_ms = Percentile(cpu_ms, 0.5);
  row.cpu_p90_ms = Percentile(cpu_ms, 0.9);
  row.samples_per_line = double(samples) / lines;
  row.projections_per_line = double(projections) / lines;
  row.hits_per_line = double(hits) / lines;
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  int reps = 15, seeds = 3, num_lines = 1500;
  double pose_error_scale = 1.0;
  bool defaults_only = false;
  std::string only;         // "step", "cell" or "descriptor": that part of the sweep alone
  std::string camera_name;  // one model only
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--reps" && i + 1 < argc) {
      reps = std::atoi(argv[++i]);
    } else if (arg == "--seeds" && i + 1 < argc) {
      seeds = std::atoi(argv[++i]);
    } else if (arg == "--lines" && i + 1 < argc) {
      num_lines = std::atoi(argv[++i]);
    } else if (arg == "--pose-error-scale" && i + 1 < argc) {
      pose_error_scale = std::atof(argv[++i]);
    } else if (arg == "--camera" && i + 1 < argc) {
      camera_name = argv[++i];
    } else if (arg == "--only" && i + 1 < argc) {
      only = argv[++i];
    } else if (arg == "--defaults-only") {
      defaults_only = true;
    } else {
      std::fprintf(stderr,
                   "usage: bench_line_matching [--reps N] [--seeds N] [--lines N] "
                   "[--pose-error-scale X] [--camera MODEL] [--defaults-only | --only "
                   "step|cell|descriptor]\n");
      return 2;
    }
  }
  const LineMatchOptions defaults;
  std::vector<LineMatchOptions> sweep;
  sweep.push_back(defaults);
  const auto wanted = [&](const char* part) {
    return !defaults_only && (only.empty() || only == part);
  };
  if (wanted("step")) {
    for (const float radius : {4.f, 6.f, 8.f, 12.f}) {
      for (const double step : {4.0, 6.0, 8.0, 10.0, 12.0, 16.0}) {
        if (step > 2.0 * radius) continue;  // windows would leave gaps along the curve
        LineMatchOptions options = defaults;
        options.step_px = step;
        options.radius_px = radius;
        sweep.push_back(options);
      }
    }
  }
  if (wanted("cell")) {  // the search grid's cell size at the default step and radius
    for (const int cell : {0, 4, 8, 16}) {
      LineMatchOptions options = defaults;
      options.search_cell_px = cell;
      sweep.push_back(options);
    }
  }
  if (wanted("descriptor")) {  // the descriptor thresholds at the default step and radius
    for (const int max_hamming : {50, 64, 80, 100}) {
      for (const float ratio : {0.7f, 0.8f, 0.9f}) {
        LineMatchOptions options = defaults;
        options.max_hamming_distance = max_hamming;
        options.ratio = ratio;
        sweep.push_back(options);
      }
    }
  }
  std::printf("pose error: %.1f x (2 cm, 0.2 deg); %d seeds x %d repetitions\n", pose_error_scale,
              seeds, reps);
  std::printf("defaults: step_px %.1f radius_px %.1f max_hamming %d ratio %.2f max_samples %d\n",
              defaults.step_px, defaults.radius_px, defaults.max_hamming_distance, defaults.ratio,
              defaults.max_samples_per_line);
  std::printf(
      "| camera | lines | keypoints | step_px | radius_px | hamming | ratio | cell_px | recall | "
      "precision | projected/line | in image/line | scored/line | cpu ms median | cpu ms p90 | "
      "wall ms median |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const CameraModel model :
       {CameraModel::kPerspective, CameraModel::kFisheye, CameraModel::kEquirectangular}) {
    if (!camera_name.empty() && camera_name != CameraModelName(model)) continue;
    std::vector<testing::LineScene> scenes;
    long keypoints = 0;
    for (int s = 0; s < seeds; ++s) {
      testing::LineSceneOptions options;
      options.model = model;
      options.num_lines = num_lines;
      options.seed = 100 + s;
      scenes.push_back(testing::MakeLineScene(options));
      keypoints += scenes.back().keypoints.size();
    }
    for (const LineMatchOptions& options : sweep) {
      const Row row = Run(scenes, options, reps, pose_error_scale);
      std::printf(
          "| %s | %d | %ld | %.0f | %.0f | %d | %.1f | %d | %.3f | %.4f | %.1f | %.1f | %.1f | "
          "%.2f | %.2f | %.2f |\n",
          CameraModelName(model), num_lines, keypoints / seeds, options.step_px, options.radius_px,
          options.max_hamming_distance, options.ratio, options.search_cell_px, row.recall,
          row.precision, row.projections_per_line, row.samples_per_line, row.hits_per_line,
          row.cpu_median_ms, row.cpu_p90_ms, row.median_ms);
      std::fflush(stdout);
    }
  }
  return 0;
}
