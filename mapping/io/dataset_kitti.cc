// KITTI odometry layout: <seq>/image_0/NNNNNN.png, <seq>/calib.txt, <seq>/times.txt, and the
// ground truth in <seq>/poses.txt or, in KITTI's own tree (dataset/sequences/<seq>,
// dataset/poses/<seq>.txt), ../../poses/<seq>.txt.

#include <filesystem>
#include <sstream>

#include "mapping/io/atomic_file.h"
#include "mapping/io/dataset_readers.h"
#include "slam/util/error.h"

namespace lcv::mapping::internal {
namespace {

namespace fs = std::filesystem;

// fx fy cx cy from the P0 line of calib.txt ("P0: p00 p01 ... p23", row-major 3x4).
slam::CameraParams ReadKittiCalibration(const std::string& path) {
  std::istringstream in(ReadTextFile(path));
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (line.rfind("P0:", 0) != 0) continue;
    std::istringstream values(line.substr(3));
    double p[12];
    int count = 0;
    while (count < 12 && values >> p[count]) ++count;
    std::string rest;
    if (count != 12 || (values >> rest)) {
      throw InputError(path, "line " + std::to_string(number) +
                                 ": P0 needs 12 numbers (row-major 3x4 projection matrix)");
    }
    slam::CameraParams camera;
    camera.name = "KITTI " + FolderName(fs::path(path).parent_path().string()) + " image_0";
    camera.model = slam::CameraModel::kPerspective;
    camera.fx = p[0];
    camera.cx = p[2];
    camera.fy = p[5];
    camera.cy = p[6];
    camera.fps = 10.0;
    if (p[1] != 0.0 || p[4] != 0.0 || p[8] != 0.0 || p[9] != 0.0 || p[10] != 1.0) {
      throw InputError(path, "line " + std::to_string(number) +
                                 ": P0 is not of the form [fx 0 cx tx; 0 fy cy ty; 0 0 1 tz]");
    }
    return camera;
  }
  throw InputError(path, "no 'P0:' line (the projection matrix of camera 0)");
}

}  // namespace

ReaderResult ReadKitti(const std::string& path, const DatasetOptions& options) {
  const std::string image_dir = JoinPath(path, "image_0");
  if (!IsDirectory(image_dir)) throw InputError(path, "not a KITTI sequence: no image_0/ folder");
  const std::vector<std::string> images = ListImageFiles(image_dir);
  if (images.empty()) throw InputError(image_dir, "no images");

  ReaderResult result;
  slam::CameraParams camera;
  const std::string calib = JoinPath(path, "calib.txt");
  if (options.camera_file) {
    result.camera_source = *options.camera_file;  // OpenDataset reads it
  } else {
    if (!IsFile(calib)) {
      throw InputError(calib, "missing (KITTI calibration); or pass a camera file (--camera)");
    }
    camera = ReadKittiCalibration(calib);
    result.camera_source = calib;
  }

  std::vector<DatasetFrame> frames(images.size());
  const std::string times_path = JoinPath(path, "times.txt");
  std::vector<double> times;
  if (IsFile(times_path)) {
    times = ReadTimesFile(times_path);
    if (times.size() != images.size()) {
      throw InputError(times_path, std::to_string(times.size()) + " timestamps for " +
                                       std::to_string(images.size()) + " images in image_0/");
    }
  }
  for (std::size_t i = 0; i < images.size(); ++i) {
    frames[i].index = i;
    frames[i].image_path = images[i];
    frames[i].timestamp = times.empty() ? static_cast<double>(i) / 10.0 : times[i];
  }

  // Ground truth: poses.txt beside the images, or KITTI's dataset/poses/<seq>.txt.
  std::string poses_path = JoinPath(path, "poses.txt");
  if (!IsFile(poses_path)) {
    fs::path seq = fs::path(path).lexically_normal();
    if (!seq.has_filename()) seq = seq.parent_path();
    const fs::path official = seq.parent_path().parent_path() / "poses" / (FolderName(path) + ".txt");
    poses_path = official.string();
  }
  if (IsFile(poses_path)) {
    const Trajectory gt = ReadTrajectory(poses_path, TrajectoryFormat::kKitti);
    if (gt.poses.size() != images.size()) {
      throw InputError(poses_path, std::to_string(gt.poses.size()) + " poses for " +
                                       std::to_string(images.size()) + " images in image_0/");
    }
    for (std::size_t i = 0; i < images.size(); ++i) {
      frames[i].world_from_cam = gt.poses[i].cam_from_world.Inverse();
    }
  }
  result.dataset = std::make_unique<Dataset>("kitti", path, camera, std::move(frames));
  return result;
}

}  // namespace lcv::mapping::internal
