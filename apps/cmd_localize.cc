// `lcv localize`: per-frame p6L localization of a dataset's images in a published line cloud
// (slam/module/line_cloud_localizer.h), the baseline of Speciale et al. (CVPR 2019) and the cost
// side of the mitigation benchmark (docs/audit.md). Frames are independent: no tracking, no
// motion prior. With ground truth, errors are measured WITHOUT alignment, so the map must be in
// the ground truth's frame (`lcv map transform --sim3-align-to` brings a SLAM map there).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "apps/args.h"
#include "apps/command.h"
#include "mapping/io/atomic_file.h"
#include "mapping/io/dataset.h"
#include "mapping/io/map_file.h"
#include "mapping/io/trajectory.h"
#include "slam/feature/orb_extractor.h"
#include "slam/geometry/so3.h"
#include "slam/module/line_cloud_localizer.h"
#include "slam/system.h"
#include "slam/util/error.h"

namespace lcv::apps {
namespace {

using nlohmann::json;

double Median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

json NumberOrNull(double x) { return std::isfinite(x) ? json(x) : json(nullptr); }

int RunLocalize(int argc, char** argv) {
  ArgParser args(
      "lcv localize --map LINE_CLOUD --dataset DIR [--sequence client] [--frames A:B:S] "
      "--trajectory-out FILE [--stats-out FILE.json]",
      "Localizes every selected frame of a dataset on its own in a line cloud: ORB features\n"
      "matched to the line descriptors (Hamming 2-NN, ratio test, one-to-one), p6L in RANSAC\n"
      "(Speciale et al. CVPR 2019; orientation-free bearing-to-plane error) and Gauss-Newton on\n"
      "the inliers. Writes the localized frames' poses (TUM). With ground truth, each frame's\n"
      "rotation and camera-centre errors are measured without alignment (the map must be in the\n"
      "ground truth's frame) and a frame counts as a success when both are within the limits.",
      "lcv localize --map scene_lines.lcmap --dataset scene --sequence client --frames 0::4 "
      "--trajectory-out p6l.txt --stats-out p6l.json");
  args.AddOption("--map", "LINE_CLOUD", "the line cloud (.lcmap or .json; lines need descriptors)");
  args.AddOption("--dataset", "DIR", "dataset folder (any layout `lcv slam` reads)");
  args.AddOption("--format", "NAME", "dataset format: auto, kitti, tum, euroc, lcv, images, video",
                 "auto");
  args.AddOption("--sequence", "NAME", "lcv scene folders: the sequence (map, client)", "client");
  args.AddOption("--camera", "FILE", "camera file replacing the dataset's intrinsics");
  args.AddOption("--frames", "A:B:S",
                 "frame selection START:END:STEP (Python slice; slices joined by commas select "
                 "their union, e.g. 0:24:2,80::2)",
                 ":");
  args.AddOption("--trajectory-out", "FILE", "poses of the localized frames, TUM format");
  args.AddOption("--stats-out", "FILE.json", "per-frame results and summary");
  args.AddOption("--num-features", "N", "ORB features per image (0: as lcv slam)", "0");
  args.AddOption("--max-error-px", "PX", "RANSAC inlier threshold (bearing-plane angle x focal)",
                 "3");
  args.AddOption("--ratio", "R", "descriptor ratio test", "0.8");
  args.AddOption("--min-inliers", "N", "inliers needed to accept a pose", "12");
  args.AddOption("--max-trials", "N",
                 "RANSAC trials at most (a p6L sample costs ~4 ms: a frame that fails costs N of them)",
                 "1000");
  args.AddOption("--max-position-error", "M", "success: camera-centre error at most M (map units)",
                 "0.5");
  args.AddOption("--max-rotation-error", "DEG", "success: rotation error at most DEG", "2");
  args.AddOption("--seed", "N", "RANSAC seed", "1");
  if (!args.Parse(argc, argv)) return kExitOk;
  args.CheckOutputs({"--trajectory-out", "--stats-out"});  // before any work

  const std::string map_path = args.Get("--map");
  const std::string dataset_path = args.Get("--dataset");
  const std::string trajectory_out = args.Get("--trajectory-out");
  slam::LineCloudLocalizerOptions options;
  options.max_error_px = args.GetDouble("--max-error-px");
  options.ratio = args.GetDouble("--ratio");
  options.min_num_inliers = args.GetInt("--min-inliers");
  options.min_num_matches = std::max(6, options.min_num_inliers);
  options.random_seed = args.GetSeed();
  options.max_ransac_trials = args.GetInt("--max-trials");
  if (const std::string problem = options.Problem(); !problem.empty()) {
    throw UsageError("localizer settings: " + problem);
  }
  const double max_position_error = args.GetDouble("--max-position-error");
  const double max_rotation_error_deg = args.GetDouble("--max-rotation-error");
  if (!(max_position_error > 0) || !(max_rotation_error_deg > 0)) {
    throw UsageError("--max-position-error and --max-rotation-error must be > 0");
  }

  mapping::DatasetOptions dataset_options;
  dataset_options.format = args.Get("--format");
  dataset_options.sequence = args.Get("--sequence");
  dataset_options.camera_file = args.GetOptional("--camera");
  std::string selection_error;
  const auto selection = mapping::FrameSelection::Parse(args.Get("--frames"), &selection_error);
  if (!selection) throw UsageError("--frames: " + selection_error);
  dataset_options.frames = *selection;

  std::cerr << "lcv localize: reading " << map_path << "\n";
  const slam::Map line_cloud = mapping::ReadMap(map_path);
  const auto dataset = mapping::OpenDataset(dataset_path, dataset_options);
  const std::unique_ptr<slam::Camera> camera = slam::MakeCamera(dataset->camera());
  const slam::LineCloudLocalizer localizer(line_cloud, *camera, options);
  if (localizer.num_matchable_lines() < 6) {
    throw InputError(map_path, std::to_string(localizer.num_matchable_lines()) +
                                   " lines with descriptors: p6L needs at least 6");
  }
  slam::OrbExtractorOptions orb;
  orb.num_features = args.GetInt("--num-features");
  if (orb.num_features <= 0) {
    orb.num_features = slam::DefaultNumFeatures(camera->model(), camera->cols(), camera->rows());
  }
  slam::OrbExtractor extractor(orb);
  std::cerr << "lcv localize: " << dataset->size() << " frames, " << localizer.num_matchable_lines()
            << " matchable lines, threshold " << localizer.max_error_rad() << " rad\n";

  const auto start = std::chrono::steady_clock::now();
  mapping::Trajectory trajectory;
  json per_frame = json::array();
  std::vector<double> position_errors, rotation_errors, seconds;
  int localized = 0, with_truth = 0, successes = 0;
  std::vector<slam::Keypoint> keypoints;
  std::vector<slam::OrbDescriptor> descriptors;
  for (size_t i = 0; i < dataset->size(); ++i) {
    const mapping::DatasetFrame& frame = dataset->frames()[i];
    const auto frame_start = std::chrono::steady_clock::now();
    extractor.Extract(dataset->LoadImage(i, true), cv::Mat(), &keypoints, &descriptors);
    const slam::LineCloudLocalization r = localizer.Localize(keypoints, descriptors);
    seconds.push_back(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - frame_start).count());
    json entry{{"index", frame.index},     {"timestamp", frame.timestamp},
               {"features", r.num_features}, {"matches", r.num_matches},
               {"inliers", r.num_inliers},   {"trials", r.num_trials},
               {"localized", r.success},     {"seconds", seconds.back()}};
    if (!r.success) entry["failure"] = r.failure;
    if (r.success) {
      ++localized;
      trajectory.poses.push_back({frame.timestamp, r.cam_from_world});
    }
    if (frame.world_from_cam) {
      ++with_truth;
      if (r.success) {
        const slam::Rigid3d truth = frame.world_from_cam->Inverse();
        const double position = (r.cam_from_world.Center() - truth.Center()).norm();
        const double rotation_deg =
            slam::AngularDistance(r.cam_from_world.rotation, truth.rotation) * 180.0 / M_PI;
        position_errors.push_back(position);
        rotation_errors.push_back(rotation_deg);
        const bool success =
            position <= max_position_error && rotation_deg <= max_rotation_error_deg;
        successes += success;
        entry["position_error"] = position;
        entry["rotation_error_deg"] = rotation_deg;
        entry["success"] = success;
      } else {
        entry["success"] = false;
      }
    }
    per_frame.push_back(entry);
  }
  const double total_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  mapping::WriteTrajectory(trajectory, trajectory_out, mapping::TrajectoryFormat::kTum);
  const int frames = static_cast<int>(dataset->size());
  if (auto stats_out = args.GetOptional("--stats-out")) {
    json stats{{"map", map_path},
               {"dataset", dataset_path},
               {"frames", frames},
               {"localized", localized},
               {"lines_matchable", localizer.num_matchable_lines()},
               {"max_error_px", options.max_error_px},
               {"max_error_rad", localizer.max_error_rad()},
               {"median_seconds_per_frame", Median(seconds)},
               {"seconds", total_seconds},
               {"per_frame", per_frame}};
    if (with_truth > 0) {
      stats["ground_truth"] = {
          {"frames", with_truth},
          {"success", successes},
          {"success_rate", static_cast<double>(successes) / with_truth},
          {"max_position_error", max_position_error},
          {"max_rotation_error_deg", max_rotation_error_deg},
          {"median_position_error", NumberOrNull(Median(position_errors))},
          {"median_rotation_error_deg", NumberOrNull(Median(rotation_errors))}};
    }
    mapping::WriteFileAtomically(*stats_out, stats.dump(2) + "\n");
  }
  std::printf("localized %d/%d frames in %s (%.1f s, median %.0f ms/frame)\n", localized, frames,
              map_path.c_str(), total_seconds, 1e3 * Median(seconds));
  if (with_truth > 0) {
    std::printf(
        "ground truth: %d/%d frames within %.3g m and %.3g deg (%.1f%%); median errors of the "
        "localized: %.3f m, %.3f deg\n",
        successes, with_truth, max_position_error, max_rotation_error_deg,
        100.0 * successes / with_truth, Median(position_errors), Median(rotation_errors));
  }
  std::printf("wrote %s\n", trajectory_out.c_str());
  return kExitOk;
}

}  // namespace
LCV_REGISTER_COMMAND("localize", "per-frame p6L localization in a line cloud", RunLocalize);
}  // namespace lcv::apps
