// SLAM benchmark (not run by ctest): runs the engine over datasets and prints, per dataset, the
// tracking time per frame (median / mean / p95, feature extraction included), the share of
// frames tracked after initialization and the APE after Sim(3) alignment, so that every change
// to the engine can be compared on the same inputs.
//
// Usage: bench_slam [--scale S] [--num-features N] [--threads] [--frames A:B:S]
//                   [--repeat N] [DATASET ...]
//   DATASET   any folder mapping/io's OpenDataset reads (default: ../shared/data/kitti00,
//             relative to the working directory: run it from the repository root); for an
//             `lcv synth` scene folder its client sequence.
//   --scale   resize the images (and the intrinsics) by S first, e.g. 0.5157 turns KITTI's
//             1241x376 into 640x194 (the 640-pixel budget).
//   --threads run local mapping on its own thread (default: deterministic, mapping inline,
//             whose time is then reported apart as mapping_ms).
//   --realtime feed frames at the dataset's rate (by timestamps), as a live camera would.
// Targets (issue "Visual SLAM engine, part 1"): >= 95% tracked, KITTI APE RMSE < 1.0 m over
// 117 m, synthetic APE < 1% of the path, median tracking <= 20 ms at 640x360.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numeric>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "mapping/eval/trajectory_error.h"
#include "mapping/io/dataset.h"
#include "slam/system.h"

namespace {

using namespace lcv;

struct Stats {
  double median = 0, mean = 0, p95 = 0;
};

Stats Summarize(std::vector<double> v) {
  Stats s;
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  s.median = n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
  s.mean = std::accumulate(v.begin(), v.end(), 0.0) / n;
  s.p95 = v[std::min(n - 1, static_cast<size_t>(std::ceil(0.95 * n)) - 1)];
  return s;
}

struct BenchOptions {
  double scale = 1.0;
  int num_features = 0;  // 0: the default
  bool threads = false;
  std::string frames = ":";
  int repeat = 1;
  bool realtime = false;
};

int RunOne(const std::string& path, const BenchOptions& bench) {
  mapping::DatasetOptions dataset_options;
  std::string error;
  const auto selection = mapping::FrameSelection::Parse(bench.frames, &error);
  if (!selection) {
    std::fprintf(stderr, "--frames: %s\n", error.c_str());
    return 2;
  }
  dataset_options.frames = *selection;
  dataset_options.sequence = "client";  // lcv scene folders: the client sequence
  const auto dataset = mapping::OpenDataset(path, dataset_options);
  slam::CameraParams camera = dataset->camera();
  if (bench.scale != 1.0) {
    camera.cols = static_cast<int>(std::lround(camera.cols * bench.scale));
    camera.rows = static_cast<int>(std::lround(camera.rows * bench.scale));
    // Pixel centres: x' + 0.5 = s (x + 0.5).
    camera.fx *= bench.scale;
    camera.fy *= bench.scale;
    camera.cx = bench.scale * (camera.cx + 0.5) - 0.5;
    camera.cy = bench.scale * (camera.cy + 0.5) - 0.5;
  }
  // Load every image first: the benchmark times the engine, not the disk.
  std::vector<cv::Mat> images;
  for (size_t i = 0; i < dataset->size(); ++i) {
    cv::Mat image = dataset->LoadImage(i, true);
    if (bench.scale != 1.0) {
      cv::Mat resized;
      cv::resize(image, resized, cv::Size(camera.cols, camera.rows), 0, 0, cv::INTER_AREA);
      image = resized;
    }
    images.push_back(image);
  }
  double path_length = 0.0;
  const mapping::Trajectory gt = dataset->GroundTruth();
  for (size_t i = 1; i < gt.poses.size(); ++i) {
    path_length +=
        (gt.poses[i].cam_from_world.Center() - gt.poses[i - 1].cam_from_world.Center()).norm();
  }

  for (int run = 0; run < bench.repeat; ++run) {
    slam::SystemOptions options;
    options.deterministic = !bench.threads;
    options.live = bench.threads && bench.realtime;  // as lcv slam --realtime (no frame dropping)
    options.features.num_features = bench.num_features > 0
                                        ? bench.num_features
                                        : slam::DefaultNumFeatures(camera.model, camera.cols, camera.rows);
    options.keyframe_policy.max_frames =
        std::max(1, static_cast<int>(std::lround(camera.fps > 0 ? camera.fps : 10.0)));
    slam::System system(camera, options);
    std::vector<double> tracking_ms, extraction_ms, mapping_ms;
    int tracked = 0, first_tracked = -1;
    const auto start = std::chrono::steady_clock::now();
    for (size_t i = 0; i < images.size(); ++i) {
      if (bench.realtime) {
        const double due_s = dataset->frames()[i].timestamp - dataset->frames()[0].timestamp;
        std::this_thread::sleep_until(
            start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                        std::chrono::duration<double>(due_s)));
      }
      const slam::FrameResult r = system.TrackImage(images[i], dataset->frames()[i].timestamp);
      tracking_ms.push_back(r.tracking_ms);
      extraction_ms.push_back(r.extraction_ms);
      mapping_ms.push_back(r.mapping_ms);
      if (r.state == slam::TrackingState::kTracking) {
        ++tracked;
        if (first_tracked < 0) first_tracked = static_cast<int>(i);
      }
    }
    system.Finish();
    const double wall_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const int after_init = first_tracked < 0 ? 0 : static_cast<int>(images.size()) - first_tracked;
    const Stats t = Summarize(tracking_ms), e = Summarize(extraction_ms), m = Summarize(mapping_ms);

    std::printf("%s (%s, %dx%d, %s, %d features, %s)\n", dataset->path().c_str(),
                dataset->format().c_str(), camera.cols, camera.rows,
                slam::CameraModelName(camera.model), options.features.num_features,
                bench.threads ? (bench.realtime ? "mapping thread, real-time feed" : "mapping thread")
                              : "deterministic");
    std::printf("  frames %zu, tracked %d = %.1f%% after initialization at frame %d; keyframes %d, "
                "points %d, initializations %d, wall %.1f s\n",
                images.size(), tracked, after_init ? 100.0 * tracked / after_init : 0.0,
                first_tracked, system.NumKeyframes(), system.NumLandmarks(),
                system.NumInitializations(), wall_s);
    std::printf("  tracking ms  median %.2f  mean %.2f  p95 %.2f  (extraction median %.2f; "
                "mapping/queue wait mean %.2f)\n",
                t.median, t.mean, t.p95, e.median, m.mean);
    if (!gt.poses.empty()) {
      const mapping::Trajectory est = mapping::MakeTrajectory(system.FrameTrajectory());
      mapping::TrajectoryErrorOptions ape_options;
      ape_options.alignment = mapping::TrajectoryAlignment::kSim3;
      const auto ape = mapping::ComputeApe(gt, est, ape_options);
      if (ape.problem) {
        std::printf("  APE: %s\n", ape.problem->c_str());
      } else {
        std::printf("  APE (Sim3) RMSE %.4f m over %d poses, path %.1f m (%.2f%% of the path), "
                    "max %.4f\n",
                    ape.translation.rmse, ape.matched, path_length,
                    path_length > 0 ? 100.0 * ape.translation.rmse / path_length : 0.0,
                    ape.translation.max);
      }
    }
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  BenchOptions bench;
  std::vector<std::string> datasets;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "%s needs a value\n", arg.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (arg == "--scale") {
      bench.scale = std::atof(value().c_str());
    } else if (arg == "--num-features") {
      bench.num_features = std::atoi(value().c_str());
    } else if (arg == "--threads") {
      bench.threads = true;
    } else if (arg == "--realtime") {
      bench.realtime = true;
    } else if (arg == "--frames") {
      bench.frames = value();
    } else if (arg == "--repeat") {
      bench.repeat = std::max(1, std::atoi(value().c_str()));
    } else if (arg == "-h" || arg == "--help") {
      std::printf("usage: bench_slam [--scale S] [--num-features N] [--threads] [--realtime] [--frames A:B:S] "
                  "[--repeat N] [DATASET ...]\n");
      return 0;
    } else if (!arg.empty() && arg[0] == '-') {
      std::fprintf(stderr, "unknown option %s\n", arg.c_str());
      return 2;
    } else {
      datasets.push_back(arg);
    }
  }
  if (!(bench.scale > 0.0)) {
    std::fprintf(stderr, "--scale must be > 0\n");
    return 2;
  }
  if (datasets.empty()) datasets.push_back("../shared/data/kitti00");
  int status = 0;
  for (const std::string& path : datasets) {
    try {
      status |= RunOne(path, bench);
    } catch (const std::exception& e) {
      std::fprintf(stderr, "bench_slam: %s\n", e.what());
      status |= 1;
    }
  }
  return status;
}
