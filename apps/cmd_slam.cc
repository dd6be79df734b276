// `lcv slam`: monocular visual SLAM over a dataset (tracking + local mapping), writing the
// frame and keyframe trajectories (TUM), the map and per-frame statistics.
#include <algorithm>
#include <chrono>
#include <thread>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <numeric>
#include <sstream>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "apps/args.h"
#include "apps/command.h"
#include "apps/live_camera.h"
#include "apps/map_camera_check.h"
#include "apps/slam_config.h"
#include "apps/slam_timing_stats.h"
#include "mapping/eval/trajectory_error.h"
#include "mapping/io/atomic_file.h"
#include "mapping/io/dataset.h"
#include "mapping/io/map_file.h"
#include "mapping/io/trajectory.h"
#include "mapping/io/vocabulary_file.h"
#include "slam/system.h"
#include "slam/util/error.h"

namespace lcv::apps {
namespace {

using nlohmann::json;

// path with ".tag" before its extension: "out/map.lcmap" -> "out/map.lost1.lcmap".
std::string PathWithTag(const std::string& path, const std::string& tag) {
  const size_t slash = path.find_last_of('/');
  const size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash) ||
      dot == (slash == std::string::npos ? 0 : slash + 1)) {
    return path + "." + tag;
  }
  return path.substr(0, dot) + "." + tag + path.substr(dot);
}


int RunSlam(int argc, char** argv) {
  ArgParser args(
      "lcv slam --dataset DIR --trajectory-out FILE [--config FILE] [--frames A:B:S] "
      "[--map-out MAP] [--stats-out FILE.json] [--deterministic]",
      "Runs monocular visual SLAM (ORB features, tracking and local-mapping threads, local BA)\n"
      "over a dataset in frame order, and writes the tracked frames' trajectory (TUM, camera-to-\n"
      "world), the keyframe trajectory, the map and per-frame statistics. Lost frames are left\n"
      "out of the trajectory; frames seen while initializing are in it when they could be posed\n"
      "against the new map once it existed. Progress goes to stderr.",
      "lcv slam --dataset ../shared/data/kitti00 --trajectory-out kitti.txt "
      "--stats-out kitti.json --map-out kitti.lcmap");
  args.AddOption("--dataset", "DIR",
                 "dataset folder (or video file); formats: kitti, tum, euroc, lcv, images, video");
  args.AddOption("--format", "NAME", "dataset format: auto, kitti, tum, euroc, lcv, images, video",
                 "auto");
  args.AddOption("--sequence", "NAME", "lcv scene folders: the sequence to run (map, client)",
                 "client");
  args.AddOption("--camera", "FILE", "camera file replacing the dataset's intrinsics");
  args.AddOption("--config", "FILE",
                 "settings (YAML or JSON): sections Feature, Initializer, Tracking, Mapping, "
                 "KeyframeInserter, Relocalization, LoopClosing, LineCloud (e.g. close_loops, "
                 "virtual_information: constant|derived), System");
  args.AddOption("--frames", "A:B:S",
                 "frame selection START:END:STEP (Python slice; slices joined by commas select "
                 "their union, e.g. 0:24:2,80::2)",
                 ":");
  args.AddOption("--trajectory-out", "FILE",
                 "tracked frames' poses, TUM format (a map lost and never merged: FILE.lostK "
                 "beside it, before the extension, in that map's own frame)");
  args.AddOption("--keyframes-out", "FILE", "keyframe poses, TUM format",
                 "<trajectory-out>.keyframes.txt");
  args.AddOption("--map-out", "MAP",
                 "the map (.json readable, else MessagePack .lcmap); a map lost and never "
                 "merged goes beside it as MAP.lostK, and the run's own map as MAP.own when it "
                 "never joined the --map-in map (then MAP is that map)");
  args.AddOption("--stats-out", "FILE.json",
                 "statistics: frames, tracked, keyframes, points, initializations, tracking_ms "
                 "{median, mean, p90, p95, p99, max}, map_lock_ms per thread {max, p99}, "
                 "frames_dropped, keyframes_refused, per-frame records");
  args.AddOption("--num-features", "N",
                 "ORB features per image (overrides the config; default: 2000 at 1241x376, "
                 "scaled with the pixel count, clamped to [1000, 2000])");
  args.AddOption("--seed", "N", "seed of the randomized steps (RANSAC)", "1");
  args.AddSwitch("--realtime",
                 "live camera: frames arrive at the dataset's own rate (by timestamps); when "
                 "tracking falls behind the waiting frame is dropped (frames_dropped), and when "
                 "mapping falls behind keyframes are refused (keyframes_refused)");
  args.AddOption("--background-nice", "N",
                 "threads: run local mapping, loop closing / global BA (and --realtime's camera "
                 "stand-in) N nice levels below tracking, 0..19 (0: same priority)", "5");
  args.AddOption("--tracking-rt-priority", "N",
                 "with --realtime: run tracking under real-time scheduling (SCHED_FIFO) at "
                 "priority N, 1..99, so that background work never delays a frame (needs "
                 "CAP_SYS_NICE or RLIMIT_RTPRIO; refused: normal scheduling and a warning); 0: "
                 "normal scheduling", "10");
  args.AddSwitch("--deterministic",
                 "map and close loops inline after each keyframe (one thread): identical results "
                 "run to run");
  args.AddOption("--vocabulary", "FILE",
                 "BoW vocabulary for relocalization and loop closing (`lcv vocab train`); "
                 "'none' turns both off", "the shipped synthetic vocabulary");
  args.AddSwitch("--no-loop-closing", "no loop detection / correction / global BA");
  args.AddSwitch("--no-relocalization", "lost tracking re-initializes instead of relocalizing");
  args.AddOption("--map-in", "MAP",
                 "start from this saved map (an `lcv slam --map-out` map) instead of "
                 "initializing: the first frames relocalize in it; it is extended unless "
                 "--localization-only");
  args.AddOption("--loop-edges-out", "FILE",
                 "closed loops as 'query_keyframe_id matched_keyframe_id' lines (for `lcv render "
                 "--loop-edges`)");
  args.AddSwitch("--localization-only",
                 "with --map-in: track in the loaded map without changing it (no keyframes, no "
                 "new points, no loop closing); not with a line cloud alone, whose client maps "
                 "on its own to register into it");
  if (!args.Parse(argc, argv)) return kExitOk;
  // Every output checked before the run, so a typo does not cost the whole run (issue 16).
  args.CheckOutputs(
      {"--trajectory-out", "--map-out", "--stats-out", "--loop-edges-out"});
  // --keyframes-out's default is derived from --trajectory-out (its help text is not a path).
  if (args.Has("--keyframes-out")) {
    args.CheckOutputs({"--keyframes-out"});
  } else if (args.Has("--trajectory-out")) {
    mapping::CheckOutputPath(args.Get("--trajectory-out") + ".keyframes.txt", "--keyframes-out");
  }

  const std::string dataset_path = args.Get("--dataset");
  const std::string trajectory_out = args.Get("--trajectory-out");

  slam::SystemOptions options = OptionsWithoutCameraDefaults();
  if (auto config = args.GetOptional("--config")) ReadSlamConfig(*config, &options);
  if (args.Has("--num-features")) {
    const int n = args.GetInt("--num-features");
    if (n < 100) throw UsageError("--num-features: must be >= 100");
    options.features.num_features = n;
  }
  if (args.Has("--deterministic")) options.deterministic = true;
  if (args.Has("--background-nice")) {
    const int nice = args.GetInt("--background-nice");
    if (nice < 0 || nice > 19) throw UsageError("--background-nice: must be in 0..19");
    options.background_nice = nice;
  }
  // A live camera does not wait for mapping: keyframes are refused instead (docs/slam.md).
  if (args.Has("--realtime")) options.live = true;
  const int tracking_rt_priority = args.GetInt("--tracking-rt-priority");
  if (tracking_rt_priority < 0 || tracking_rt_priority > 99) {
    throw UsageError("--tracking-rt-priority: must be in 0..99");
  }
  if (args.Has("--seed") || !args.Has("--config")) {
    options.seed = args.GetSeed("--seed");
  }
  options.initializer.seed = options.seed;
  if (args.Has("--no-loop-closing")) options.loop_closing.enabled = false;
  if (args.Has("--no-relocalization")) options.relocalization.enabled = false;
  if (args.Has("--localization-only")) {
    if (!args.Has("--map-in")) throw UsageError("--localization-only needs --map-in MAP");
    options.localization_only = true;
  }
  const std::string vocabulary_path =
      args.Has("--vocabulary") ? args.Get("--vocabulary") : mapping::DefaultVocabularyPath();
  double vocabulary_load_ms = 0.0;
  if (vocabulary_path != "none" &&
      (options.loop_closing.enabled || options.relocalization.enabled)) {
    const auto load_start = std::chrono::steady_clock::now();
    options.vocabulary = mapping::ReadVocabularyFile(vocabulary_path);
    vocabulary_load_ms = std::chrono::duration<double, std::milli>(
                             std::chrono::steady_clock::now() - load_start).count();
  }
  std::optional<slam::Map> map_in;
  double map_load_ms = 0.0;
  const auto map_load_start = std::chrono::steady_clock::now();
  if (auto path = args.GetOptional("--map-in")) map_in = mapping::ReadMap(*path);

  mapping::DatasetOptions dataset_options;
  dataset_options.format = args.Get("--format");
  dataset_options.sequence = args.Get("--sequence");
  dataset_options.camera_file = args.GetOptional("--camera");
  std::string selection_error;
  const auto selection = mapping::FrameSelection::Parse(args.Get("--frames"), &selection_error);
  if (!selection) throw UsageError("--frames: " + selection_error);
  dataset_options.frames = *selection;
  const std::unique_ptr<mapping::Dataset> dataset = mapping::OpenDataset(dataset_path, dataset_options);
  const slam::CameraParams& camera = dataset->camera();
  ApplyCameraDefaults(camera, &options);

  std::cerr << "lcv slam: " << dataset->format() << " " << dataset->path() << ", "
            << dataset->size() << " frames, " << camera.cols << "x" << camera.rows << " "
            << slam::CameraModelName(camera.model)
            << ", " << options.features.num_features << " features"
            << (options.deterministic ? ", deterministic" : ", mapping thread") << "\n";

  slam::System system(camera, options);
  if (map_in) {
    std::cerr << MapCameraWarnings(*map_in, args.Get("--map-in"), camera,
                                   args.GetOptional("--camera").value_or(dataset->path()));
    try {
      system.LoadMap(*map_in);
    } catch (const std::invalid_argument& e) {
      throw InputError(args.Get("--map-in"), e.what());
    }
    map_load_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() -
                                                            map_load_start).count();
    std::cerr << "lcv slam: loaded " << args.Get("--map-in") << ": " << system.NumKeyframes()
              << " keyframes, " << system.NumLandmarks() << " points, " << map_in->lines.size()
              << " lines, " << map_in->server_keyframes.size() << " server keyframes in "
              << map_load_ms << " ms" << (options.localization_only ? ", localization only" : "")
              << "\n";
    const slam::SystemStats loaded = system.Stats();
    if (!loaded.line_cloud_problem.empty()) {
      std::cerr << "lcv slam: warning: " << args.Get("--map-in") << ": "
                << loaded.line_cloud_problem << "\n";
    }
  }
  const bool line_cloud_in = map_in && !map_in->lines.empty();
  bool warned_not_relocalized = false;
  std::vector<slam::FrameResult> results;
  results.reserve(dataset->size());
  int tracked = 0;
  const bool realtime = args.Has("--realtime");
  // Dataset index of each result (live mode drops frames).
  std::vector<size_t> result_frames;
  auto track = [&](size_t i, const cv::Mat& image) {
    const slam::FrameResult result = system.TrackImage(image, dataset->frames()[i].timestamp);
    results.push_back(result);
    result_frames.push_back(i);
    tracked += result.state == slam::TrackingState::kTracking;
    if ((i + 1) % 20 == 0 || i + 1 == dataset->size()) {
      std::cerr << "lcv slam: frame " << (i + 1) << "/" << dataset->size() << ": "
                << slam::TrackingStateName(result.state) << ", " << result.num_matches
                << " matches";
      if (line_cloud_in) std::cerr << " (" << result.num_line_matches << " on lines)";
      std::cerr << ", " << tracked << " tracked, " << system.NumKeyframes() << " keyframes\n";
    }
    if (line_cloud_in && !warned_not_relocalized) {
      const slam::SystemStats now = system.Stats();
      if (!now.relocalized_in_line_cloud &&
          now.line_cloud_attempts >= options.line_cloud.warn_after_keyframes) {
        warned_not_relocalized = true;
        std::cerr << "lcv slam: warning: not relocalized in " << args.Get("--map-in")
                  << " after " << now.line_cloud_attempts << " keyframes (last attempt: "
                  << now.line_cloud_last_failure << "); tracking goes on in the client's frame\n";
      }
    }
  };
  int frames_dropped = 0;
  LiveCameraRun live_run;
  if (realtime) {
    LiveCameraOptions live_options;
    live_options.camera_nice = options.background_nice;
    live_options.tracking_rt_priority = tracking_rt_priority;
    live_run = RunLiveCamera(*dataset, track, live_options);
    frames_dropped = live_run.frames_dropped;
    if (!live_run.priority_error.empty()) {
      std::cerr << "lcv slam: warning: tracking ran under normal scheduling ("
                << live_run.priority_error << "): expect more latency jitter\n";
    }
  } else {
    for (size_t i = 0; i < dataset->size(); ++i) track(i, dataset->LoadImage(i, true));
  }
  system.Finish();

  const std::vector<slam::TimedPose> frames = system.FrameTrajectory();
  const std::vector<slam::TimedPose> keyframes = system.KeyframeTrajectory();
  mapping::WriteTrajectory(mapping::MakeTrajectory(frames), trajectory_out, mapping::TrajectoryFormat::kTum);
  const std::string keyframes_out =
      args.Has("--keyframes-out") ? args.Get("--keyframes-out") : trajectory_out + ".keyframes.txt";
  mapping::WriteTrajectory(mapping::MakeTrajectory(keyframes), keyframes_out, mapping::TrajectoryFormat::kTum);
  if (auto map_out = args.GetOptional("--map-out")) {
    slam::Map map = system.ExportMap();
    map.description = "lcv slam --dataset " + dataset_path +
                      (map_in ? " --map-in " + args.Get("--map-in") : std::string());
    mapping::WriteMap(map, *map_out);
  }
  const slam::SystemStats system_stats = system.Stats();
  // A camera that started outside a loaded map and never reached it: --map-out holds the loaded
  // map (so --map-in X --map-out X loses nothing), and the run's own map goes beside it.
  const bool own_map_apart = system_stats.loaded_map && !line_cloud_in &&
                             !system_stats.trajectory_in_loaded_map_frame;
  std::string own_map_file;
  if (auto map_out = args.GetOptional("--map-out"); map_out && own_map_apart) {
    slam::Map own = system.ExportMap(system.TrajectoryMap());
    own.description = "lcv slam --dataset " + dataset_path + ": the run's own map, which never "
                      "joined --map-in " + args.Get("--map-in");
    own_map_file = PathWithTag(*map_out, "own");
    mapping::WriteMap(own, own_map_file);
  }
  // The kept maps the outputs leave out (lost for good, never merged), each in its own frame,
  // beside the outputs: T.lost1.txt, MAP.lost1.lcmap, ... (docs/slam.md "Which segment the
  // outputs hold"). Nothing a run mapped is dropped.
  const std::vector<int> left_out = system.LeftOutMaps();
  std::vector<std::string> left_out_files;
  for (size_t k = 0; k < left_out.size(); ++k) {
    const std::string tag = "lost" + std::to_string(k + 1);
    const std::string trajectory_path = PathWithTag(trajectory_out, tag);
    mapping::WriteTrajectory(mapping::MakeTrajectory(system.FrameTrajectory(left_out[k])),
                             trajectory_path, mapping::TrajectoryFormat::kTum);
    left_out_files.push_back(trajectory_path);
    if (auto map_out = args.GetOptional("--map-out")) {
      slam::Map map = system.ExportMap(left_out[k]);
      map.description = "lcv slam --dataset " + dataset_path + ": a map lost and never merged";
      const std::string map_path = PathWithTag(*map_out, tag);
      mapping::WriteMap(map, map_path);
      left_out_files.push_back(map_path);
    }
  }

  if (auto loop_edges_out = args.GetOptional("--loop-edges-out")) {
    std::ostringstream text;
    for (const slam::LoopEvent& loop : system_stats.loops) {
      if (loop.closed) text << loop.query_keyframe_id << " " << loop.match_keyframe_id << "\n";
    }
    mapping::WriteFileAtomically(*loop_edges_out, text.str());
  }

  std::vector<double> tracking_ms, extraction_ms;
  int lost = 0, initializing = 0;
  for (const slam::FrameResult& r : results) {
    tracking_ms.push_back(r.tracking_ms);
    extraction_ms.push_back(r.extraction_ms);
    lost += r.state == slam::TrackingState::kLost;
    initializing += r.state == slam::TrackingState::kInitializing;
  }
  const Summary tracking_summary = Summarize(tracking_ms);
  int first_tracked = -1;
  for (size_t i = 0; i < results.size(); ++i) {
    if (results[i].state == slam::TrackingState::kTracking) {
      first_tracked = static_cast<int>(i);
      break;
    }
  }
  const int after_init = first_tracked < 0 ? 0 : static_cast<int>(results.size()) - first_tracked;

  std::optional<mapping::TrajectoryErrorReport> ape;
  // In the line cloud's frame: the error with no alignment of the client's own (meaningful when
  // the line cloud is in the ground truth's frame, as in the benchmarks).
  std::optional<mapping::TrajectoryErrorReport> ape_server_frame;
  if (dataset->has_ground_truth() && frames.size() >= 3) {
    mapping::TrajectoryErrorOptions ape_options;
    ape_options.alignment = mapping::TrajectoryAlignment::kSim3;
    ape = mapping::ComputeApe(dataset->GroundTruth(), mapping::MakeTrajectory(frames), ape_options);
    if (ape->problem) ape.reset();
    if (system_stats.trajectory_in_line_cloud_frame) {
      ape_options.alignment = mapping::TrajectoryAlignment::kNone;
      ape_server_frame = mapping::ComputeApe(dataset->GroundTruth(),
                                             mapping::MakeTrajectory(frames), ape_options);
      if (ape_server_frame->problem) ape_server_frame.reset();
    }
  }
  std::vector<double> line_matches, lines_searched, lines_backed_off;
  for (const slam::FrameResult& r : results) {
    if (r.state != slam::TrackingState::kTracking) continue;
    line_matches.push_back(r.num_line_matches);
    lines_searched.push_back(r.num_lines_searched);
    lines_backed_off.push_back(r.num_lines_backed_off);
  }
  const double first_timestamp = results.empty() ? 0.0 : results.front().timestamp;
  const double relocalization_time_s =
      system_stats.line_cloud_registration_timestamp - first_timestamp;

  if (auto stats_out = args.GetOptional("--stats-out")) {
    json stats;
    stats["dataset"] = dataset_path;
    stats["format"] = dataset->format();
    stats["frames"] = results.size();
    stats["tracked"] = tracked;
    stats["lost"] = lost;
    stats["initializing"] = initializing;
    stats["tracked_ratio_after_init"] = after_init > 0 ? static_cast<double>(tracked) / after_init : 0.0;
    stats["keyframes"] = system.NumKeyframes();
    stats["points"] = system.NumLandmarks();
    stats["initializations"] = system.NumInitializations();
    stats["frames_dropped"] = frames_dropped;
    stats["keyframes_refused"] = system_stats.keyframes_refused;
    stats["keyframes_reanchored"] = system_stats.keyframes_reanchored;
    stats["relocalizations_skipped"] = system_stats.relocalizations_skipped;
    stats["line_cloud_checks"] = system_stats.line_cloud_checks;
    stats["line_cloud_check_refusals"] = system_stats.line_cloud_check_refusals;
    stats["line_cloud_check_adoptions"] = system_stats.line_cloud_check_adoptions;
    stats["line_cloud_checks_cut_short"] = system_stats.line_cloud_checks_cut_short;
    stats["line_cloud_relocalizations"] = system_stats.line_cloud_relocalizations;
    stats["line_cloud_relocalization_attempts"] =
        system_stats.line_cloud_relocalization_attempts;
    stats["live"] = realtime;
    stats["loop_closing_input"] = {{"copies", system_stats.loop_input_copies},
                                   {"copy_ms_total", system_stats.loop_input_copy_ms},
                                   {"copy_ms_max", system_stats.loop_input_copy_max_ms},
                                   {"keyframes", system_stats.loop_input_keyframes},
                                   {"keyframes_at_finish",
                                    system_stats.loop_input_keyframes_at_finish},
                                   {"keyframes_unexamined",
                                    system_stats.loop_input_keyframes_unexamined}};
    stats["map_lock_ms"] = {{"tracking", LockJson(system_stats.map_lock_tracking)},
                            {"mapping", LockJson(system_stats.map_lock_mapping)},
                            {"loop_closing", LockJson(system_stats.map_lock_loop_closing)}};
    stats["deterministic"] = options.deterministic;
    stats["background_nice"] = options.background_nice;
    stats["thread_nice"] = {{"tracking", system_stats.tracking_thread_nice},
                            {"mapping", system_stats.mapping_thread_nice},
                            {"loop_closing", system_stats.loop_closing_thread_nice}};
    stats["tracking_rt_priority"] = live_run.tracking_rt_priority;
    stats["tracking_rt_suspensions"] = live_run.realtime_suspensions;
    stats["thread_priority_error"] = !system_stats.thread_priority_error.empty()
                                         ? system_stats.thread_priority_error
                                         : live_run.priority_error;
    stats["vocabulary"] = options.vocabulary ? vocabulary_path : std::string("none");
    stats["vocabulary_load_ms"] = vocabulary_load_ms;
    if (map_in) {
      stats["map_in"] = args.Get("--map-in");
      stats["map_load_ms"] = map_load_ms;
      stats["localization_only"] = options.localization_only;
      if (system_stats.loaded_map) {
        // A point map with keyframes: false while the run's own map (a camera that started
        // outside the loaded one) has not merged into it.
        stats["trajectory_in_map_frame"] = system_stats.trajectory_in_loaded_map_frame;
      }
    }
    stats["loop_closing"] = options.vocabulary != nullptr && options.loop_closing.enabled &&
                            !options.localization_only;
    stats["loops_detected"] = system_stats.loops_detected;
    stats["loops_closed"] = system_stats.loops_closed;
    stats["relocalizations"] = system_stats.relocalizations;
    stats["maps_kept"] = system_stats.maps_kept;
    stats["maps_merged"] = system_stats.maps_merged;
    stats["maps_left_out"] = system_stats.maps_left_out;
    json loops = json::array();
    for (const slam::LoopEvent& loop : system_stats.loops) {
      loops.push_back({{"query_keyframe", loop.query_keyframe_id},
                       {"match_keyframe", loop.match_keyframe_id},
                       {"timestamp", loop.timestamp},
                       {"matches", loop.num_matches},
                       {"closed", loop.closed},
                       {"merged_maps", loop.merged_maps},
                       {"line_cloud", loop.line_cloud}});
    }
    stats["loops"] = loops;
    json global_ba = json::array();
    for (const slam::SystemStats::GlobalBARun& run : system_stats.global_ba) {
      global_ba.push_back({{"timestamp", run.timestamp},
                           {"applied", run.applied},
                           {"line_cloud", run.line_cloud},
                           {"keyframes", run.keyframes},
                           {"server_keyframes", run.server_keyframes},
                           {"points", run.points},
                           {"lines", run.lines},
                           {"observations", run.observations},
                           {"virtual_observations", run.virtual_observations},
                           {"iterations", run.iterations},
                           {"initial_cost", run.initial_cost},
                           {"final_cost", run.final_cost},
                           {"outliers", run.outliers},
                           {"solve_ms", run.solve_ms},
                           {"message", run.message}});
    }
    stats["global_ba"] = global_ba;
    stats["bundle_adjustment"] = {
        {"local_runs", system_stats.local_ba_runs},
        {"local_stopped_early", system_stats.local_ba_stopped_early},
        {"local_ms_total", system_stats.local_ba_ms},
        {"pose_graph_runs", system_stats.pose_graph_runs},
        {"pose_graph_ms_total", system_stats.pose_graph_ms},
        {"global_runs", system_stats.global_ba_runs},
        {"global_ms_total", system_stats.global_ba_ms}};
    stats["tracking_ms"] = SummaryJson(tracking_summary);
    stats["extraction_ms"] = SummaryJson(Summarize(extraction_ms));
    stats.update(TrackingTimingJson(results));
    // LC-VSLAM client: always present; null times when not relocalized in a line cloud.
    stats["relocalized"] = system_stats.relocalized_in_line_cloud;
    stats["trajectory_in_line_cloud_frame"] = system_stats.trajectory_in_line_cloud_frame;
    stats["relocalization_time_s"] =
        system_stats.relocalized_in_line_cloud ? json(relocalization_time_s) : json(nullptr);
    stats["restored_points"] = system_stats.restored_points;
    stats["line_matches_per_frame"] = SummaryJson(Summarize(line_matches));
    stats["lines_searched_per_frame"] = SummaryJson(Summarize(lines_searched));
    stats["lines_backed_off_per_frame"] = SummaryJson(Summarize(lines_backed_off));
    if (line_cloud_in) {
      stats["line_cloud"] = {
          {"lines", map_in->lines.size()},
          {"server_keyframes", map_in->server_keyframes.size()},
          {"attempts", system_stats.line_cloud_attempts},
          {"detachments", system_stats.line_cloud_detachments},
          {"restored_points_released", system_stats.restored_points_released},
          {"method", system_stats.line_cloud_method},
          {"inliers", system_stats.line_cloud_inliers},
          {"scale", system_stats.line_cloud_scale},
          {"registration_ms", system_stats.line_cloud_registration_ms},
          {"problem", system_stats.line_cloud_problem},
          {"last_failure", system_stats.line_cloud_last_failure}};
      json attempt_log = json::array();
      for (const auto& a : system_stats.line_cloud_attempt_log) {
        attempt_log.push_back({{"keyframe", a.keyframe_id},
                               {"timestamp", a.timestamp},
                               {"candidates", a.candidates},
                               {"lines", a.lines},
                               {"point_line_matches", a.point_line_matches},
                               {"point_point_matches", a.point_point_matches},
                               {"inliers", a.inliers},
                               {"method", a.method},
                               {"success", a.success},
                               {"failure", a.failure},
                               {"ms", a.time_ms},
                               {"views", a.views},
                               {"views_failure", a.views_failure},
                               {"views_ms", a.views_ms}});
      }
      stats["line_cloud"]["attempt_log"] = std::move(attempt_log);
    }
    if (ape_server_frame) {
      stats["ape_server_frame"] = {{"rmse", ape_server_frame->translation.rmse},
                                   {"rotation_rmse_deg", ape_server_frame->rotation_deg.rmse},
                                   {"matched", ape_server_frame->matched}};
    }
    if (ape) {
      stats["ape_sim3"] = {{"rmse", ape->translation.rmse},
                           {"mean", ape->translation.mean},
                           {"median", ape->translation.median},
                           {"max", ape->translation.max},
                           {"matched", ape->matched}};
    }
    json per_frame = json::array();
    for (size_t i = 0; i < results.size(); ++i) {
      const slam::FrameResult& r = results[i];
      per_frame.push_back({{"index", dataset->frames()[result_frames[i]].index},
                           {"timestamp", r.timestamp},
                           {"state", slam::TrackingStateName(r.state)},
                           {"keypoints", r.num_keypoints},
                           {"matches", r.num_matches},
                           {"line_matches", r.num_line_matches},
                           {"lines_searched", r.num_lines_searched},
                           {"lines_backed_off", r.num_lines_backed_off},
                           {"keyframe", r.is_keyframe},
                           {"relocalized", r.relocalized},
                           {"two_view", r.two_view}});
      per_frame.back().update(FrameTimingJson(r));
    }
    stats["per_frame"] = per_frame;
    mapping::WriteFileAtomically(*stats_out, stats.dump(1) + "\n");
  }

  std::printf("frames %zu, tracked %d (%.1f%% after initialization), lost %d\n", results.size(),
              tracked, after_init > 0 ? 100.0 * tracked / after_init : 0.0, lost);
  std::printf("keyframes %d, points %d, initializations %d\n", system.NumKeyframes(),
              system.NumLandmarks(), system.NumInitializations());
  std::printf("tracking ms: median %.2f, mean %.2f, p95 %.2f, p99 %.2f, max %.2f\n",
              tracking_summary.median, tracking_summary.mean, tracking_summary.p95,
              tracking_summary.p99, tracking_summary.max);
  if (realtime || system_stats.keyframes_refused > 0) {
    std::printf("live: frames dropped %d, keyframes refused %d\n", frames_dropped,
                system_stats.keyframes_refused);
  }
  if (options.vocabulary) {
    std::printf("loops detected %d, closed %d; relocalizations %d; lost maps kept %d, merged %d\n",
                system_stats.loops_detected, system_stats.loops_closed,
                system_stats.relocalizations, system_stats.maps_kept, system_stats.maps_merged);
  }
  if (ape) {
    std::printf("APE (Sim3) translation RMSE %.4f over %d poses\n", ape->translation.rmse,
                ape->matched);
  }
  if (system_stats.maps_left_out > 0) {
    std::printf("maps: %d lost map(s) never merged and left out of the outputs, which hold "
                "%zu poses\n", system_stats.maps_left_out, frames.size());
    std::cerr << "lcv slam: tracking was lost and " << system_stats.maps_left_out
              << " map(s) never merged: the trajectory and the map file hold one map, the "
                 "biggest or the one in the line cloud's frame ("
              << frames.size() << " of " << tracked << " tracked frames); the others, each in "
              << "its own frame:";
    for (const std::string& file : left_out_files) std::cerr << " " << file;
    std::cerr << "\n";
  }
  if (own_map_apart) {
    const std::optional<std::string> map_out = args.GetOptional("--map-out");
    std::printf("map: this run's map never joined the loaded map; trajectory in its own frame%s\n",
                map_out ? ", --map-out holds the loaded map" : "");
    std::cerr << "lcv slam: the camera started outside " << args.Get("--map-in")
              << " and its own map never merged into it: the trajectory is in the run's own frame"
              << (map_out ? "; " + *map_out + " holds the loaded map only, " + own_map_file +
                                " the run's own"
                          : std::string())
              << "\n";
  }
  if (line_cloud_in) {
    if (system_stats.relocalized_in_line_cloud) {
      std::printf("line cloud: relocalized at %.2f s (%s, %d inliers, scale %.4f), %d restored "
                  "points, median %.0f line matches per frame\n",
                  relocalization_time_s, system_stats.line_cloud_method.c_str(),
                  system_stats.line_cloud_inliers, system_stats.line_cloud_scale,
                  system_stats.restored_points, Summarize(line_matches).median);
      if (!system_stats.trajectory_in_line_cloud_frame) {
        std::printf("line cloud: the registered map was lost and the new one did not register; "
                    "trajectory in that map's own frame\n");
        std::cerr << "lcv slam: the map registered in " << args.Get("--map-in")
                  << " was lost; the trajectory is the new map's, in its own frame\n";
      }
    } else {
      std::printf("line cloud: not relocalized after %d keyframes; trajectory in the client's "
                  "own frame\n", system_stats.line_cloud_attempts);
      std::cerr << "lcv slam: not relocalized in " << args.Get("--map-in") << " after "
                << system_stats.line_cloud_attempts << " keyframes"
                << (system_stats.line_cloud_last_failure.empty()
                        ? std::string()
                        : " (last attempt: " + system_stats.line_cloud_last_failure + ")")
                << "\n";
    }
    if (ape_server_frame) {
      std::printf("APE (server frame, no alignment) translation RMSE %.4f over %d poses\n",
                  ape_server_frame->translation.rmse, ape_server_frame->matched);
    }
  }
  std::printf("trajectory: %s (%zu poses), keyframes: %s\n", trajectory_out.c_str(),
              frames.size(), keyframes_out.c_str());
  if (first_tracked < 0) {
    // Named like every other error: the file that failed first (issue 16).
    if (map_in) {
      std::cerr << "lcv slam: error: " << args.Get("--map-in") << ": no frame of "
                << dataset->path() << " could be localized in this map\n";
    } else {
      std::cerr << "lcv slam: error: " << dataset->path()
                << ": the map was never initialized (too little motion or texture, or wrong "
                   "camera intrinsics from "
                << args.GetOptional("--camera").value_or(dataset->path()) << "?)\n";
    }
    return kExitFailure;
  }
  return kExitOk;
}

}  // namespace
LCV_REGISTER_COMMAND("slam", "monocular visual SLAM over a dataset: trajectory, map, statistics",
                     RunSlam);
}  // namespace lcv::apps
