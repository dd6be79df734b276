// TUM RGB-D layout: rgb.txt ("timestamp rgb/NNN.png" per line, '#' comments), rgb/ images,
// groundtruth.txt (TUM trajectory, ~100 Hz), associated to the images by nearest timestamp.

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "mapping/io/atomic_file.h"
#include "mapping/io/dataset_readers.h"
#include "slam/util/error.h"

namespace lcv::mapping::internal {
namespace {

namespace fs = std::filesystem;

// Images and ground truth are associated within this time difference (TUM's associate.py
// uses 20 ms by default).
constexpr double kMaxGroundTruthTimeDifferenceS = 0.02;

// The intrinsics TUM publishes for its Kinect sensors ("fr1", "fr2", "fr3"), 640x480, 30 Hz;
// the ROS default (525, 319.5, 239.5) would be less accurate.
std::optional<slam::CameraParams> FreiburgCamera(const std::string& folder_name) {
  slam::CameraParams camera;
  camera.model = slam::CameraModel::kPerspective;
  camera.cols = 640;
  camera.rows = 480;
  camera.fps = 30.0;
  if (folder_name.find("freiburg1") != std::string::npos) {
    camera.name = "TUM RGB-D freiburg1";
    camera.fx = 517.306408;
    camera.fy = 516.469215;
    camera.cx = 318.643040;
    camera.cy = 255.313989;
    camera.distortion = {0.262383, -0.953104, -0.005358, 0.002628, 1.163314};
  } else if (folder_name.find("freiburg2") != std::string::npos) {
    camera.name = "TUM RGB-D freiburg2";
    camera.fx = 520.908620;
    camera.fy = 521.007327;
    camera.cx = 325.141442;
    camera.cy = 249.701764;
    camera.distortion = {0.231222, -0.784899, -0.003257, -0.000105, 0.917205};
  } else if (folder_name.find("freiburg3") != std::string::npos) {
    camera.name = "TUM RGB-D freiburg3";
    camera.fx = 535.4;
    camera.fy = 539.2;
    camera.cx = 320.1;
    camera.cy = 247.6;
  } else {
    return std::nullopt;
  }
  return camera;
}

}  // namespace

ReaderResult ReadTum(const std::string& path, const DatasetOptions& options) {
  const std::string list_path = JoinPath(path, "rgb.txt");
  std::istringstream in(ReadTextFile(list_path));
  std::vector<DatasetFrame> frames;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream fields(line);
    std::string stamp_text, file, extra;
    fields >> stamp_text >> file;
    if (file.empty() || (fields >> extra)) {
      throw InputError(list_path, "line " + std::to_string(number) +
                                      ": expected 'timestamp filename', got '" + line + "'");
    }
    errno = 0;
    char* end = nullptr;
    const double stamp = std::strtod(stamp_text.c_str(), &end);
    if (*end != '\0' || errno != 0 || !std::isfinite(stamp)) {
      throw InputError(list_path, "line " + std::to_string(number) + ": '" + stamp_text +
                                      "' is not a timestamp");
    }
    DatasetFrame frame;
    frame.index = frames.size();
    frame.timestamp = stamp;
    frame.image_path = JoinPath(path, file);
    frames.push_back(std::move(frame));
  }
  if (frames.empty()) throw InputError(list_path, "no images listed");
  CheckIncreasingTimestamps(frames, list_path);

  const std::string gt_path = JoinPath(path, "groundtruth.txt");
  if (IsFile(gt_path)) {
    AssignGroundTruthByTimestamp(ReadTrajectory(gt_path, TrajectoryFormat::kTum),
                                 kMaxGroundTruthTimeDifferenceS, &frames);
  }

  ReaderResult result;
  slam::CameraParams camera;
  const auto freiburg = FreiburgCamera(FolderName(path));
  if (options.camera_file || FindCameraFile(path) || !freiburg) {
    camera = RequireCameraFile(path, path, options, &result.camera_source);
  } else {
    camera = *freiburg;
    result.camera_source = path + " (published " + camera.name + " intrinsics)";
    const double span = frames.back().timestamp - frames.front().timestamp;
    if (frames.size() > 1 && span > 0) camera.fps = (frames.size() - 1) / span;
  }
  result.dataset = std::make_unique<Dataset>("tum", path, camera, std::move(frames));
  return result;
}

}  // namespace lcv::mapping::internal
