// Image-folder layouts: a plain folder of images with a camera file, and the project's own
// synthetic sequences (`lcv synth`: <seq>/images/, camera.yaml, times.txt, groundtruth.txt).

#include <cmath>
#include <filesystem>

#include "mapping/io/camera_file.h"
#include "mapping/io/dataset_readers.h"
#include "slam/util/error.h"

namespace lcv::mapping::internal {
namespace {

namespace fs = std::filesystem;

constexpr double kMaxGroundTruthTimeDifferenceS = 0.02;

// Timestamps from times.txt in dir when present (one per image), else index / fps.
void AssignTimes(const std::string& dir, double fps, bool required, std::vector<DatasetFrame>* frames) {
  const std::string times_path = JoinPath(dir, "times.txt");
  if (!IsFile(times_path)) {
    if (required) throw InputError(times_path, "missing (one timestamp per image)");
    for (DatasetFrame& frame : *frames) frame.timestamp = static_cast<double>(frame.index) / fps;
    return;
  }
  const std::vector<double> times = ReadTimesFile(times_path);
  if (times.size() != frames->size()) {
    throw InputError(times_path, std::to_string(times.size()) + " timestamps for " +
                                     std::to_string(frames->size()) + " images");
  }
  for (std::size_t i = 0; i < times.size(); ++i) (*frames)[i].timestamp = times[i];
}

std::vector<DatasetFrame> FramesOf(const std::vector<std::string>& images) {
  std::vector<DatasetFrame> frames(images.size());
  for (std::size_t i = 0; i < images.size(); ++i) {
    frames[i].index = i;
    frames[i].image_path = images[i];
  }
  return frames;
}

// Sequences of an lcv scene folder: its subfolders with an images/ folder.
std::vector<std::string> SceneSequences(const std::string& scene) {
  std::vector<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(scene, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->is_directory(ec) && IsDirectory((it->path() / "images").string())) {
      names.push_back(it->path().filename().string());
    }
  }
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace

ReaderResult ReadImageFolder(const std::string& path, const DatasetOptions& options) {
  const std::vector<std::string> images = ListImageFiles(path);
  if (images.empty()) throw InputError(path, "no image files (png, jpg, bmp, pgm, ppm, tif)");
  ReaderResult result;
  const slam::CameraParams camera = RequireCameraFile(path, path, options, &result.camera_source);
  std::vector<DatasetFrame> frames = FramesOf(images);
  AssignTimes(path, camera.fps, /*required=*/false, &frames);
  const std::string gt_path = JoinPath(path, "groundtruth.txt");
  if (IsFile(gt_path)) {
    AssignGroundTruthByTimestamp(ReadTrajectory(gt_path, TrajectoryFormat::kTum),
                                 kMaxGroundTruthTimeDifferenceS, &frames);
  }
  result.dataset = std::make_unique<Dataset>("images", path, camera, std::move(frames));
  return result;
}

ReaderResult ReadLcv(const std::string& path, const DatasetOptions& options) {
  std::string sequence_dir = path;
  if (IsFile(JoinPath(path, "scene.json")) && !IsDirectory(JoinPath(path, "images"))) {
    const std::vector<std::string> sequences = SceneSequences(path);
    if (options.sequence.empty()) {
      std::string list;
      for (const auto& name : sequences) list += (list.empty() ? "" : ", ") + name;
      throw InputError(path, "a synthetic scene with sequences {" + list +
                                 "}: choose one (--sequence NAME, or open " + JoinPath(path, "NAME") +
                                 ")");
    }
    if (std::find(sequences.begin(), sequences.end(), options.sequence) == sequences.end()) {
      throw InputError(path, "no sequence '" + options.sequence + "' (no " +
                                 JoinPath(JoinPath(path, options.sequence), "images") + " folder)");
    }
    sequence_dir = JoinPath(path, options.sequence);
  }
  const std::string image_dir = JoinPath(sequence_dir, "images");
  if (!IsDirectory(image_dir)) throw InputError(sequence_dir, "not an lcv sequence: no images/ folder");
  const std::vector<std::string> images = ListImageFiles(image_dir);
  if (images.empty()) throw InputError(image_dir, "no images");

  ReaderResult result;
  const slam::CameraParams camera =
      RequireCameraFile(sequence_dir, sequence_dir, options, &result.camera_source);
  std::vector<DatasetFrame> frames = FramesOf(images);
  AssignTimes(sequence_dir, camera.fps, /*required=*/true, &frames);

  // Ground truth: one TUM line per image, in the same order and with the same timestamps.
  const std::string gt_path = JoinPath(sequence_dir, "groundtruth.txt");
  if (IsFile(gt_path)) {
    const Trajectory gt = ReadTrajectory(gt_path, TrajectoryFormat::kTum);
    if (gt.poses.size() != frames.size()) {
      throw InputError(gt_path, std::to_string(gt.poses.size()) + " poses for " +
                                    std::to_string(frames.size()) + " images");
    }
    for (std::size_t i = 0; i < frames.size(); ++i) {
      if (std::fabs(gt.poses[i].timestamp - frames[i].timestamp) > 1e-6) {
        throw InputError(gt_path, "pose " + std::to_string(i) + ": timestamp " +
                                      FormatDoubleExact(gt.poses[i].timestamp) +
                                      " differs from times.txt (" +
                                      FormatDoubleExact(frames[i].timestamp) + ")");
      }
      frames[i].world_from_cam = gt.poses[i].cam_from_world.Inverse();
    }
  }
  result.dataset = std::make_unique<Dataset>("lcv", sequence_dir, camera, std::move(frames));
  return result;
}

}  // namespace lcv::mapping::internal
