#include "mapping/io/dataset.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>


#include "mapping/io/camera_file.h"
#include "mapping/io/dataset_readers.h"
#include "mapping/io/media.h"
#include "slam/util/error.h"

namespace lcv::mapping {
namespace fs = std::filesystem;

Dataset::Dataset(std::string format, std::string path, slam::CameraParams camera,
                 std::vector<DatasetFrame> frames)
    : format_(std::move(format)),
      path_(std::move(path)),
      camera_(std::move(camera)),
      frames_(std::move(frames)) {}

bool Dataset::has_ground_truth() const {
  return std::any_of(frames_.begin(), frames_.end(),
                     [](const DatasetFrame& f) { return f.world_from_cam.has_value(); });
}

Trajectory Dataset::GroundTruth() const {
  Trajectory trajectory;
  for (const DatasetFrame& frame : frames_) {
    if (frame.world_from_cam) {
      trajectory.poses.push_back({frame.timestamp, frame.world_from_cam->Inverse()});
    }
  }
  return trajectory;
}

void Dataset::CheckImageSize(const cv::Mat& image, const std::string& source) const {
  if (image.cols != camera_.cols || image.rows != camera_.rows) {
    throw InputError(source, "image is " + std::to_string(image.cols) + "x" +
                                 std::to_string(image.rows) + " but the camera is " +
                                 std::to_string(camera_.cols) + "x" +
                                 std::to_string(camera_.rows));
  }
}

cv::Mat Dataset::LoadImage(std::size_t i, bool grayscale) const {
  LCV_CHECK(i < frames_.size()) << i << " >= " << frames_.size();
  const std::string& path = frames_[i].image_path;
  if (!internal::IsFile(path)) throw InputError(path, "image file missing");
  cv::Mat image = ReadImageFile(path, grayscale ? ImageMode::kGray : ImageMode::kColor);
  if (image.empty()) {
    throw InputError(path, "cannot decode image");
  }
  if (image.depth() != CV_8U) {
    // 16-bit PNGs and the like: scale to 8 bits as the pipeline expects.
    cv::Mat converted;
    image.convertTo(converted, CV_8U, image.depth() == CV_16U ? 1.0 / 257.0 : 1.0);
    image = converted;
  }
  CheckImageSize(image, path);
  return image;
}

void Dataset::Select(const FrameSelection& selection) {
  if (selection.SelectsAll()) return;
  std::vector<DatasetFrame> selected;
  for (const std::size_t k : selection.Apply(frames_.size())) selected.push_back(frames_[k]);
  frames_ = std::move(selected);
}

namespace internal {

std::string JoinPath(const std::string& dir, const std::string& name) {
  if (dir.empty()) return name;
  return dir.back() == '/' ? dir + name : dir + "/" + name;
}

std::string FolderName(const std::string& path) {
  fs::path p = fs::path(path).lexically_normal();
  if (!p.has_filename()) p = p.parent_path();
  return p.filename().string();
}

bool IsDirectory(const std::string& path) {
  std::error_code ec;
  return fs::is_directory(path, ec);
}

bool IsFile(const std::string& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
}

std::vector<std::string> ListImageFiles(const std::string& dir) {
  static const char* kExtensions[] = {".png", ".jpg", ".jpeg", ".bmp", ".pgm",
                                      ".ppm", ".tif", ".tiff"};
  std::vector<std::string> files;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (!it->is_regular_file(ec)) continue;
    std::string extension = it->path().extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    for (const char* known : kExtensions) {
      if (extension == known) {
        files.push_back(it->path().string());
        break;
      }
    }
  }
  if (ec) throw InputError(dir, "cannot list folder: " + ec.message());
  std::sort(files.begin(), files.end());
  return files;
}

std::optional<std::string> FindCameraFile(const std::string& dir) {
  for (const char* name : {"camera.yaml", "camera.yml", "camera.json"}) {
    const std::string path = JoinPath(dir, name);
    if (IsFile(path)) return path;
  }
  return std::nullopt;
}

slam::CameraParams RequireCameraFile(const std::string& dir, const std::string& what,
                                     const DatasetOptions& options, std::string* source) {
  std::optional<std::string> file = options.camera_file;
  if (!file) file = FindCameraFile(dir);
  if (!file) {
    throw InputError(what, "no camera: pass a camera file (--camera FILE) or put camera.yaml in " +
                               dir);
  }
  *source = *file;
  CameraFileOptions camera_options;
  camera_options.require_image_size = false;
  return ReadCameraFile(*file, camera_options);
}

void AssignGroundTruthByTimestamp(const Trajectory& ground_truth, double max_time_difference_s,
                                  std::vector<DatasetFrame>* frames) {
  const auto& poses = ground_truth.poses;
  if (poses.empty()) return;
  for (DatasetFrame& frame : *frames) {
    const auto it = std::lower_bound(
        poses.begin(), poses.end(), frame.timestamp,
        [](const StampedPose& pose, double t) { return pose.timestamp < t; });
    std::size_t best = static_cast<std::size_t>(it - poses.begin());
    if (best == poses.size() ||
        (best > 0 && std::fabs(poses[best - 1].timestamp - frame.timestamp) <=
                         std::fabs(poses[best].timestamp - frame.timestamp))) {
      --best;
    }
    if (std::fabs(poses[best].timestamp - frame.timestamp) <= max_time_difference_s) {
      frame.world_from_cam = poses[best].cam_from_world.Inverse();
    }
  }
}

void CheckIncreasingTimestamps(const std::vector<DatasetFrame>& frames,
                               const std::string& source) {
  for (std::size_t i = 1; i < frames.size(); ++i) {
    if (!(frames[i].timestamp > frames[i - 1].timestamp)) {
      throw InputError(source, "timestamps do not increase at frame " + std::to_string(i) + " (" +
                                   FormatDoubleExact(frames[i - 1].timestamp) + " then " +
                                   FormatDoubleExact(frames[i].timestamp) + ")");
    }
  }
}

}  // namespace internal

std::optional<std::string> DetectDatasetFormat(const std::string& path) {
  using namespace internal;
  if (IsFile(path)) {
    std::string extension = fs::path(path).extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    for (const char* known : {".mp4", ".avi", ".mkv", ".mov", ".webm", ".m4v", ".mpg", ".mpeg",
                              ".wmv", ".flv", ".ogv", ".mjpeg", ".mjpg"}) {
      if (extension == known) return "video";
    }
    return std::nullopt;
  }
  if (!IsDirectory(path)) return std::nullopt;
  if (IsDirectory(JoinPath(path, "image_0"))) return "kitti";
  if (IsFile(JoinPath(path, "mav0/cam0/data.csv")) || IsFile(JoinPath(path, "cam0/data.csv"))) {
    return "euroc";
  }
  if (IsFile(JoinPath(path, "rgb.txt"))) return "tum";
  if (IsFile(JoinPath(path, "camera.txt")) && IsFile(JoinPath(path, "times.txt")) &&
      (IsDirectory(JoinPath(path, "images")) || IsFile(JoinPath(path, "images.zip")))) {
    return "tum-mono";
  }
  if (IsFile(JoinPath(path, "scene.json"))) return "lcv";
  if (IsDirectory(JoinPath(path, "images")) &&
      (IsFile(JoinPath(path, "times.txt")) || FindCameraFile(path))) {
    return "lcv";
  }
  if (!ListImageFiles(path).empty()) return "images";
  return std::nullopt;
}

std::unique_ptr<Dataset> OpenDataset(const std::string& path, const DatasetOptions& options) {
  using namespace internal;
  if (!IsDirectory(path) && !IsFile(path)) throw InputError(path, "no such file or folder");
  std::string format = options.format;
  if (format == "auto") {
    const auto detected = DetectDatasetFormat(path);
    if (!detected) {
      throw InputError(path,
                       "unknown dataset layout (expected KITTI image_0/, TUM rgb.txt or monoVO camera.txt, EuRoC "
                       "mav0/cam0/data.csv, an lcv synthetic sequence, a folder of images or a "
                       "video file)");
    }
    format = *detected;
  }
  ReaderResult result;
  if (format == "kitti") {
    result = ReadKitti(path, options);
  } else if (format == "tum") {
    result = ReadTum(path, options);
  } else if (format == "tum-mono") {
    result = ReadTumMono(path, options);
  } else if (format == "euroc") {
    result = ReadEuroc(path, options);
  } else if (format == "lcv") {
    result = ReadLcv(path, options);
  } else if (format == "images") {
    result = ReadImageFolder(path, options);
  } else if (format == "video") {
    result = ReadVideo(path, options);
  } else {
    throw InputError(path, "unknown dataset format '" + format +
                               "' (expected auto, kitti, tum, tum-mono, euroc, lcv, images or video)");
  }
  Dataset& dataset = *result.dataset;
  if (dataset.frames_.empty()) throw InputError(path, "no images in the " + format + " dataset");
  CheckIncreasingTimestamps(dataset.frames_, path);

  if (options.camera_file) {
    CameraFileOptions camera_options;
    camera_options.require_image_size = false;
    dataset.camera_ = ReadCameraFile(*options.camera_file, camera_options);
    result.camera_source = *options.camera_file;
  }
  // The image size: from the reader (video) or the first image.
  int cols = result.image_cols, rows = result.image_rows;
  std::string size_source = path;
  if (cols <= 0 || rows <= 0) {
    size_source = dataset.frames_.front().image_path;
    const cv::Mat first = ReadImageFile(size_source, ImageMode::kUnchanged);
    if (first.empty()) throw InputError(size_source, "cannot read image");
    cols = first.cols;
    rows = first.rows;
  }
  slam::CameraParams& camera = dataset.camera_;
  if (camera.cols <= 0 && camera.rows <= 0) {
    camera.cols = cols;
    camera.rows = rows;
  } else if (camera.cols != cols || camera.rows != rows) {
    throw InputError(result.camera_source,
                     "Camera: image size " + std::to_string(camera.cols) + "x" +
                         std::to_string(camera.rows) + " differs from the images' " +
                         std::to_string(cols) + "x" + std::to_string(rows) + " (" + size_source +
                         ")");
  }
  CheckCameraParams(camera, result.camera_source);

  const std::size_t total = dataset.frames_.size();
  dataset.Select(options.frames);
  if (dataset.frames_.empty()) {
    throw InputError(path, "frame selection " + options.frames.ToString() + " selects none of the " +
                               std::to_string(total) + " frames");
  }
  return std::move(result.dataset);
}

}  // namespace lcv::mapping
