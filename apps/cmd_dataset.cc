// `lcv dataset info`: what OpenDataset makes of a path (format, camera, frames, time span,
// ground truth), optionally exporting its camera file and ground-truth trajectory.
#include <iostream>
#include <string>

#include <nlohmann/json.hpp>

#include "apps/args.h"
#include "apps/command.h"
#include "mapping/io/camera_file.h"
#include "mapping/io/dataset.h"
#include "mapping/io/trajectory.h"
#include "slam/util/error.h"

namespace lcv::apps {
namespace {

int RunDatasetInfo(int argc, char** argv) {
  ArgParser args(
      "lcv dataset info PATH [--frames START:END:STEP] [--camera FILE] [options]",
      "Opens a dataset as the SLAM and rendering commands do and prints its format, camera,\n"
      "frame count, time span and whether it has ground truth. Layouts: KITTI odometry\n"
      "(image_0/, calib.txt, times.txt, poses.txt), TUM RGB-D (rgb.txt, groundtruth.txt), TUM\n"
      "monoVO (images/, times.txt, camera.txt), EuRoC (mav0/cam0/data.csv, sensor.yaml), lcv\n"
      "synthetic sequences, a folder of images or a video file with a camera file.",
      "lcv dataset info ../shared/data/kitti00 --frames 0::2 --write-gt client_gt.txt");
  args.AddPositional("PATH", "dataset folder or video file");
  args.AddOption("--frames", "START:END:STEP",
                 "frame selection, Python slice semantics (1::2 odd frames, 0::2 even; "
                 "slices joined by commas select their union)",
                 ":");
  args.AddOption("--camera", "FILE", "camera file (YAML/JSON) replacing the dataset's intrinsics");
  args.AddOption("--format", "FMT", "auto, kitti, tum, tum-mono, euroc, lcv, images, video", "auto");
  args.AddOption("--sequence", "NAME", "sequence of an lcv scene folder (map, client)");
  args.AddOption("--write-camera", "FILE", "write the dataset's camera as a camera file (YAML)");
  args.AddOption("--write-gt", "FILE",
                 "write the ground truth of the selected frames as a TUM trajectory");
  args.AddSwitch("--json", "print one JSON object instead of the summary");
  if (!args.Parse(argc, argv)) return kExitOk;
  args.CheckOutputs({"--write-camera", "--write-gt"});  // before any work

  mapping::DatasetOptions options;
  options.format = args.Get("--format");
  options.camera_file = args.GetOptional("--camera");
  options.sequence = args.GetOptional("--sequence").value_or("");
  std::string error;
  const auto frames = mapping::FrameSelection::Parse(args.Get("--frames"), &error);
  if (!frames) throw UsageError("--frames: " + error);
  options.frames = *frames;
  const std::string path = args.Positional("PATH");
  std::cerr << "lcv dataset info: opening " << path << "\n";
  const auto dataset = mapping::OpenDataset(path, options);

  const slam::CameraParams& camera = dataset->camera();
  const auto& all = dataset->frames();
  const double first = all.front().timestamp;
  const double last = all.back().timestamp;
  std::size_t with_gt = 0;
  for (const auto& frame : all) with_gt += frame.world_from_cam.has_value();

  if (const auto camera_out = args.GetOptional("--write-camera")) {
    mapping::WriteCameraFile(camera, *camera_out);
  }
  if (const auto gt_out = args.GetOptional("--write-gt")) {
    if (with_gt == 0) throw InputError(path, "no ground truth to write (--write-gt)");
    mapping::WriteTrajectory(dataset->GroundTruth(), *gt_out, mapping::TrajectoryFormat::kTum);
  }

  const char* model = slam::CameraModelName(camera.model);
  if (args.Has("--json")) {
    nlohmann::json out;
    out["path"] = dataset->path();
    out["format"] = dataset->format();
    out["frames"] = all.size();
    out["selection"] = options.frames.ToString();
    out["first_index"] = all.front().index;
    out["last_index"] = all.back().index;
    out["first_timestamp"] = first;
    out["last_timestamp"] = last;
    out["duration_s"] = last - first;
    out["ground_truth"] = with_gt > 0;
    out["frames_with_ground_truth"] = with_gt;
    out["camera"] = {{"name", camera.name},     {"model", model},     {"fx", camera.fx},
                     {"fy", camera.fy},         {"cx", camera.cx},    {"cy", camera.cy},
                     {"distortion", camera.distortion}, {"cols", camera.cols},
                     {"rows", camera.rows},     {"fps", camera.fps}};
    std::cout << out.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) << "\n";
    return kExitOk;
  }
  std::cout << "dataset   " << dataset->path() << " (" << dataset->format() << ")\n"
            << "camera    " << camera.name << ": " << model << " " << camera.cols << "x"
            << camera.rows << ", fx " << mapping::FormatDoubleExact(camera.fx) << " fy "
            << mapping::FormatDoubleExact(camera.fy) << " cx "
            << mapping::FormatDoubleExact(camera.cx) << " cy "
            << mapping::FormatDoubleExact(camera.cy) << ", " << camera.fps << " fps\n";
  bool distorted = false;
  for (const double d : camera.distortion) distorted |= d != 0.0;
  if (distorted) {
    std::cout << "distortion";
    for (const double d : camera.distortion) std::cout << " " << d;
    std::cout << "\n";
  }
  std::cout << "frames    " << all.size() << " (selection " << options.frames.ToString()
            << ", indices " << all.front().index << ".." << all.back().index << ")\n"
            << "time      " << first << " .. " << last << " s (" << last - first << " s)\n"
            << "truth     "
            << (with_gt ? "yes, " + std::to_string(with_gt) + " of " + std::to_string(all.size()) +
                              " frames"
                        : std::string("no"))
            << "\n";
  return kExitOk;
}

}  // namespace
LCV_REGISTER_COMMAND("dataset info", "format, camera, frames and ground truth of a dataset",
                     RunDatasetInfo);
}  // namespace lcv::apps
