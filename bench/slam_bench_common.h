#pragma once
// Shared parts of the SLAM benchmarks bench_loop_closing, bench_relocalization and
// bench_map_reuse (header-only: every bench/*.cc is its own executable). Loads a sequence into
// memory (the benchmarks time the engine, not the disk), runs a System over it with an optional
// per-frame image filter (blanked or skipped frames) and an optional map to start from, and
// evaluates the trajectory against ground truth (APE after Sim(3) alignment, evo's way).
//
// Frames: ground truth is world_from_cam in the dataset's world (metres); trajectories are
// cam_from_world in the SLAM map's frame (arbitrary monocular scale), aligned by Sim(3).

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <fstream>

#include <nlohmann/json.hpp>
#include <opencv2/core/mat.hpp>

#include "mapping/eval/trajectory_error.h"
#include "mapping/io/dataset.h"
#include "mapping/io/trajectory.h"
#include "mapping/io/vocabulary_file.h"
#include "slam/bow/vocabulary.h"
#include "slam/solve/umeyama.h"
#include "slam/system.h"

namespace lcv::bench {

// A sequence loaded into memory: images (8-bit gray), timestamps, ground truth.
struct LoadedSequence {
  std::string path;  // the sequence folder
  slam::CameraParams camera;
  std::vector<cv::Mat> images;
  std::vector<double> timestamps;
  mapping::Trajectory ground_truth;  // cam_from_world, same timestamps (may be empty)
  double path_length_m = 0.0;        // of the ground truth
};

// path: any dataset OpenDataset reads; for an `lcv synth` scene folder, `sequence` ("map",
// "client") picks the sequence. frames: "A:B:S". Throws lcv::InputError / std::runtime_error.
inline LoadedSequence LoadSequence(const std::string& path, const std::string& sequence,
                                   const std::string& frames = ":") {
  mapping::DatasetOptions options;
  std::string error;
  const auto selection = mapping::FrameSelection::Parse(frames, &error);
  if (!selection) throw std::runtime_error("--frames: " + error);
  options.frames = *selection;
  options.sequence = sequence;
  const auto dataset = mapping::OpenDataset(path, options);
  LoadedSequence loaded;
  loaded.path = dataset->path();
  loaded.camera = dataset->camera();
  for (size_t i = 0; i < dataset->size(); ++i) {
    loaded.images.push_back(dataset->LoadImage(i, true));
    loaded.timestamps.push_back(dataset->frames()[i].timestamp);
  }
  loaded.ground_truth = dataset->GroundTruth();
  const auto& gt = loaded.ground_truth.poses;
  for (size_t i = 1; i < gt.size(); ++i) {
    loaded.path_length_m +=
        (gt[i].cam_from_world.Center() - gt[i - 1].cam_from_world.Center()).norm();
  }
  return loaded;
}

// path empty: mapping::DefaultVocabularyPath() (LCV_VOCABULARY or the shipped vocabulary).
inline std::shared_ptr<const slam::Vocabulary> LoadVocabulary(const std::string& path) {
  return mapping::ReadVocabularyFile(path.empty() ? mapping::DefaultVocabularyPath() : path);
}

// Options every SLAM benchmark takes: --vocabulary FILE, --num-features N, --threads,
// --realtime, --json FILE.
struct CommonOptions {
  std::string vocabulary;  // empty: the shipped one
  int num_features = 0;    // 0: DefaultNumFeatures of the image size
  bool threads = false;    // mapping and loop closing on their own threads
  bool realtime = false;   // with threads: feed at the sequence's rate
  std::string json_path;
};

// The settings `lcv slam` uses by default for a camera (bench_slam's): the feature budget for
// the image size, at most one second between keyframes; deterministic unless threads; the
// vocabulary of relocalization and loop closing.
inline slam::SystemOptions BenchSystemOptions(
    const slam::CameraParams& camera, const CommonOptions& common,
    const std::shared_ptr<const slam::Vocabulary>& vocabulary) {
  slam::SystemOptions options;
  options.deterministic = !common.threads;
  // A live camera: keyframes refused rather than waited for (docs/slam.md "Threads").
  options.live = common.threads && common.realtime;
  options.features.num_features = common.num_features > 0
                                       ? common.num_features
                                       : slam::DefaultNumFeatures(camera.model, camera.cols, camera.rows);
  options.keyframe_policy.max_frames =
      std::max(1, static_cast<int>(std::lround(camera.fps > 0 ? camera.fps : 10.0)));
  options.vocabulary = vocabulary;
  return options;
}

// What the filter does with frame i: feed it unchanged, feed a black image, or not feed it.
enum class FrameAction { kFeed, kBlank, kSkip };

struct SystemRun {
  std::vector<int> frame_index;             // per fed frame: its index in the sequence
  std::vector<slam::FrameResult> results;   // per fed frame
  std::vector<slam::TimedPose> trajectory;  // System::FrameTrajectory()
  slam::SystemStats stats;
  int keyframes = 0;
  int landmarks = 0;
  int initializations = 0;
  double wall_s = 0.0;     // TrackImage calls + Finish
  double load_map_s = 0.0;  // System::LoadMap (when a map was given)
  std::optional<slam::Map> map;  // ExportMap() when asked for
};

// Runs a fresh System over the sequence. map: LoadMap'ed first when not null. action: per
// frame index (null: feed all). realtime: feed frames at the sequence's rate (by timestamps), as
// a live camera would, instead of as fast as tracking returns (with the mapping thread, feeding
// as fast as possible starves mapping and is no test of it). Progress every 50 frames on stderr
// when label is not empty.
inline SystemRun RunSystem(const LoadedSequence& sequence, const slam::SystemOptions& options,
                           const slam::Map* map,
                           const std::function<FrameAction(int)>& action, bool export_map,
                           const std::string& label, bool realtime = false) {
  using Clock = std::chrono::steady_clock;
  SystemRun run;
  slam::System system(sequence.camera, options);
  if (map != nullptr) {
    const auto t0 = Clock::now();
    system.LoadMap(*map);
    run.load_map_s = std::chrono::duration<double>(Clock::now() - t0).count();
  }
  const cv::Mat black = cv::Mat::zeros(sequence.camera.rows, sequence.camera.cols, CV_8UC1);
  const auto start = Clock::now();
  for (size_t i = 0; i < sequence.images.size(); ++i) {
    const FrameAction what = action ? action(static_cast<int>(i)) : FrameAction::kFeed;
    if (what == FrameAction::kSkip) continue;
    if (realtime) {
      const double due_s = sequence.timestamps[i] - sequence.timestamps.front();
      std::this_thread::sleep_until(start + std::chrono::duration_cast<Clock::duration>(
                                                std::chrono::duration<double>(due_s)));
    }
    const cv::Mat& image = what == FrameAction::kBlank ? black : sequence.images[i];
    run.frame_index.push_back(static_cast<int>(i));
    run.results.push_back(system.TrackImage(image, sequence.timestamps[i]));
    if (!label.empty() && (i + 1) % 50 == 0) {
      const slam::SystemStats s = system.Stats();
      std::fprintf(stderr, "%s: frame %zu/%zu %s, loops %d/%d, relocalizations %d, maps kept %d "
                   "merged %d\n",
                   label.c_str(), i + 1, sequence.images.size(),
                   slam::TrackingStateName(run.results.back().state), s.loops_detected,
                   s.loops_closed, s.relocalizations, s.maps_kept, s.maps_merged);
    }
  }
  system.Finish();
  run.wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  run.trajectory = system.FrameTrajectory();
  run.stats = system.Stats();
  run.keyframes = system.NumKeyframes();
  run.landmarks = system.NumLandmarks();
  run.initializations = system.NumInitializations();
  if (export_map) run.map = system.ExportMap();
  return run;
}

struct ApeSummary {
  std::optional<std::string> problem;  // why there is no APE
  int matched = 0;
  double rmse_m = 0.0, max_m = 0.0;
  double percent_of_path = 0.0;
  slam::Sim3d gt_from_est;
  mapping::TrajectoryErrorReport report;  // per-pose errors
};

// APE of the tracked poses after Sim(3) alignment (the monocular default).
inline ApeSummary Sim3Ape(const LoadedSequence& sequence,
                          const std::vector<slam::TimedPose>& trajectory) {
  ApeSummary ape;
  if (sequence.ground_truth.poses.empty()) {
    ape.problem = "no ground truth";
    return ape;
  }
  mapping::TrajectoryErrorOptions options;
  options.alignment = mapping::TrajectoryAlignment::kSim3;
  ape.report = mapping::ComputeApe(sequence.ground_truth, mapping::MakeTrajectory(trajectory),
                                   options);
  ape.problem = ape.report.problem;
  if (ape.problem) return ape;
  ape.matched = ape.report.matched;
  ape.rmse_m = ape.report.translation.rmse;
  ape.max_m = ape.report.translation.max;
  ape.percent_of_path =
      sequence.path_length_m > 0 ? 100.0 * ape.rmse_m / sequence.path_length_m : 0.0;
  ape.gt_from_est = ape.report.gt_from_est;
  return ape;
}

// RMSE of the camera-centre errors of the poses with timestamp in [t_begin, t_end] under a
// given alignment gt_from_est (no re-alignment); count = number of such poses (0: rmse 0).
struct AlignedError {
  int count = 0;
  double rmse_m = 0.0;
  double max_m = 0.0;
};
inline AlignedError ErrorUnderAlignment(const LoadedSequence& sequence,
                                        const std::vector<slam::TimedPose>& trajectory,
                                        const slam::Sim3d& gt_from_est, double t_begin,
                                        double t_end) {
  const mapping::Trajectory est = mapping::MakeTrajectory(trajectory);
  const mapping::TrajectoryAssociation pairs =
      mapping::AssociateByTimestamp(sequence.ground_truth, est, 0.01);
  AlignedError e;
  double sse = 0.0;
  for (size_t k = 0; k < pairs.gt_indices.size(); ++k) {
    const auto& gt = sequence.ground_truth.poses[pairs.gt_indices[k]];
    if (gt.timestamp < t_begin || gt.timestamp > t_end) continue;
    const Eigen::Vector3d c = gt_from_est * est.poses[pairs.est_indices[k]].cam_from_world.Center();
    const double d = (c - gt.cam_from_world.Center()).norm();
    sse += d * d;
    e.max_m = std::max(e.max_m, d);
    ++e.count;
  }
  if (e.count > 0) e.rmse_m = std::sqrt(sse / e.count);
  return e;
}

// Sim(3) alignment on the tracked poses with timestamp <= t_end only (e.g. a loop's start), so
// that the error of later poses shows the drift accumulated since. Empty when degenerate.
inline std::optional<slam::Sim3d> AlignOnPrefix(const LoadedSequence& sequence,
                                                const std::vector<slam::TimedPose>& trajectory,
                                                double t_end) {
  const mapping::Trajectory est = mapping::MakeTrajectory(trajectory);
  const mapping::TrajectoryAssociation pairs =
      mapping::AssociateByTimestamp(sequence.ground_truth, est, 0.01);
  std::vector<Eigen::Vector3d> src, dst;
  for (size_t k = 0; k < pairs.gt_indices.size(); ++k) {
    const auto& gt = sequence.ground_truth.poses[pairs.gt_indices[k]];
    if (gt.timestamp > t_end) continue;
    src.push_back(est.poses[pairs.est_indices[k]].cam_from_world.Center());
    dst.push_back(gt.cam_from_world.Center());
  }
  slam::Sim3d gt_from_est;
  if (!slam::AlignUmeyama(src, dst, true, &gt_from_est)) return std::nullopt;
  return gt_from_est;
}

inline int CountTracked(const std::vector<slam::FrameResult>& results) {
  return static_cast<int>(std::count_if(results.begin(), results.end(), [](const auto& r) {
    return r.state == slam::TrackingState::kTracking;
  }));
}

// Value of a command-line option, or exits with status 2 when it is missing.
inline std::string OptionValue(int argc, char** argv, int* i) {
  if (*i + 1 >= argc) {
    std::fprintf(stderr, "%s needs a value\n", argv[*i]);
    std::exit(2);
  }
  return argv[++*i];
}


// Parses the command line: the common options, the program's own through own_option (called
// with each option and the index of argv; it returns true when it took the option, reading a
// value with OptionValue) and positional datasets. Returns -1 to go on, else the exit status:
// 0 after --help (prints usage), 2 on an unknown option or no dataset (prints no_dataset).
inline int ParseBenchArguments(int argc, char** argv, const char* usage, const char* no_dataset,
                               const std::function<bool(const std::string&, int*)>& own_option,
                               CommonOptions* common, std::vector<std::string>* datasets) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--vocabulary") {
      common->vocabulary = OptionValue(argc, argv, &i);
    } else if (arg == "--num-features") {
      common->num_features = std::atoi(OptionValue(argc, argv, &i).c_str());
    } else if (arg == "--threads") {
      common->threads = true;
    } else if (arg == "--realtime") {
      common->realtime = true;
    } else if (arg == "--json") {
      common->json_path = OptionValue(argc, argv, &i);
    } else if (arg == "-h" || arg == "--help") {
      std::printf("%s\n", usage);
      return 0;
    } else if (own_option(arg, &i)) {
      continue;
    } else if (!arg.empty() && arg[0] == '-') {
      std::fprintf(stderr, "unknown option %s\n", arg.c_str());
      return 2;
    } else {
      datasets->push_back(arg);
    }
  }
  if (datasets->empty()) {
    std::fprintf(stderr, "%s\n", no_dataset);
    return 2;
  }
  return -1;
}

// The benchmarks' main loop: loads the vocabulary, runs run_dataset on every dataset (a failing
// dataset is reported and the others still run), writes the JSON results when json_path is set.
// Returns the process exit status: 0, 1 when a dataset or the vocabulary failed.
inline int RunEachDataset(
    const char* program, const std::vector<std::string>& datasets, const CommonOptions& common,
    const std::function<nlohmann::json(const std::string&,
                                       const std::shared_ptr<const slam::Vocabulary>&)>&
        run_dataset) {
  int status = 0;
  nlohmann::json results = nlohmann::json::array();
  try {
    const auto vocabulary = LoadVocabulary(common.vocabulary);
    for (const std::string& path : datasets) {
      try {
        results.push_back(run_dataset(path, vocabulary));
      } catch (const std::exception& e) {
        std::fprintf(stderr, "%s: %s: %s\n", program, path.c_str(), e.what());
        status = 1;
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", program, e.what());
    return 1;
  }
  if (!common.json_path.empty()) std::ofstream(common.json_path) << results.dump(2) << "\n";
  return status;
}

}  // namespace lcv::bench
