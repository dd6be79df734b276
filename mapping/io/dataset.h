#pragma once
// Image sequences with their camera and (when known) ground truth, behind one interface, read
// from the datasets' native layouts. OpenDataset detects the layout of a path:
//
//  format   layout (path is the folder unless noted)
//  kitti    image_0/NNNNNN.png, calib.txt (P0: fx fy cx cy), times.txt; ground truth from
//           poses.txt in the folder or ../../poses/<seq>.txt (KITTI's own tree). Image size
//           from the first image.
//  tum      rgb.txt ("timestamp rgb/file.png"), optional groundtruth.txt (TUM poses at any rate,
//           associated by nearest timestamp within 20 ms); camera: --camera, camera.yaml /
//           camera.json in the folder, or the published intrinsics of freiburg1/2/3 when the
//           folder name says rgbd_dataset_freiburgN_*.
//  tum-mono TUM monoVO: images/, times.txt ("id timestamp exposure"), camera.txt (DSO format:
//           Pinhole, RadTan, EquiDistant; the FOV model needs --camera); no ground truth.
//  euroc    mav0/cam0/data.csv + mav0/cam0/sensor.yaml (pinhole, radial-tangential; the path
//           may be the sequence folder or mav0). Ground truth from
//           mav0/state_groundtruth_estimate0/data.csv (the IMU body pose) is converted to the
//           camera with the camera's T_BS (body_from_cam) from sensor.yaml, so it is the pose of
//           cam0 in EuRoC's world frame; nearest timestamp within 20 ms.
//  lcv      the project's synthetic layout (written by `lcv synth`): <seq>/images/*.png,
//           <seq>/camera.yaml, <seq>/times.txt, <seq>/groundtruth.txt (TUM, one line per image,
//           same order). The path is the sequence folder, or the scene folder (with scene.json)
//           plus DatasetOptions::sequence ("map" / "client").
//  images   any folder of images (png, jpg, jpeg, bmp, pgm, ppm, tif, tiff; sorted by name)
//           with a camera file (--camera, or camera.yaml / camera.json in the folder);
//           optional times.txt (else index / fps) and groundtruth.txt (TUM, by timestamp).
//  video    a video file cv::VideoCapture can decode, with a camera file (--camera, or
//           camera.yaml / camera.json beside it); timestamps index / fps of the container
//           (of the camera file when the container states none).
//
// A camera file given in DatasetOptions::camera_file replaces the dataset's own intrinsics.
// Missing cols/rows are taken from the images; a camera whose size differs from the images'
// is an error. Frames may then be selected (FrameSelection, e.g. "1::2").
//
// Every problem with the files is an lcv::InputError naming the file and what is wrong.

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "mapping/io/frame_selection.h"
#include "mapping/io/trajectory.h"
#include "slam/camera/camera.h"
#include "slam/geometry/rigid3.h"

namespace lcv::mapping {

struct DatasetFrame {
  std::size_t index = 0;     // position in the whole sequence (before selection)
  double timestamp = 0.0;    // seconds, strictly increasing along frames()
  std::string image_path;    // empty for video frames
  // Ground-truth pose, camera-to-world (the camera centre is world_from_cam.translation), in
  // the dataset's world frame and metric units when the dataset has them.
  std::optional<slam::Rigid3d> world_from_cam;
};

struct DatasetOptions {
  // "auto" (detect from the path) or one of kitti, tum, tum-mono, euroc, lcv, images, video.
  std::string format = "auto";
  // Camera file replacing the dataset's own intrinsics (mapping/io/camera_file.h).
  std::optional<std::string> camera_file;
  FrameSelection frames;
  // lcv scene folder only: the sequence subfolder to open ("map", "client").
  std::string sequence;
};

// Thread safety: all const methods may be called concurrently, except LoadImage on a video
// (the decoder keeps a position): call it from one thread.
class Dataset {
 public:
  Dataset(std::string format, std::string path, slam::CameraParams camera,
          std::vector<DatasetFrame> frames);
  virtual ~Dataset() = default;

  const std::string& format() const { return format_; }  // "kitti", "tum", ...
  // The folder or file the frames come from (for lcv scenes: the sequence folder).
  const std::string& path() const { return path_; }
  const slam::CameraParams& camera() const { return camera_; }
  const std::vector<DatasetFrame>& frames() const { return frames_; }  // selected frames
  std::size_t size() const { return frames_.size(); }
  // True when at least one selected frame has a ground-truth pose.
  bool has_ground_truth() const;
  // The ground-truth poses of the selected frames that have one (timestamps of the frames).
  Trajectory GroundTruth() const;

  // Image of frames()[i], 8-bit: one channel when grayscale, else 3-channel BGR. Throws
  // lcv::InputError naming the file when it is missing or unreadable or its size differs from
  // the camera's; std::logic_error when i >= size().
  virtual cv::Mat LoadImage(std::size_t i, bool grayscale = true) const;

  // Keeps only the frames at the given positions of frames() (used by OpenDataset).
  void Select(const FrameSelection& selection);

 protected:
  friend std::unique_ptr<Dataset> OpenDataset(const std::string& path,
                                              const DatasetOptions& options);

  // Checks that image has the camera's size; throws lcv::InputError(source, ...) otherwise.
  void CheckImageSize(const cv::Mat& image, const std::string& source) const;

  std::string format_;
  std::string path_;
  slam::CameraParams camera_;
  std::vector<DatasetFrame> frames_;
};

// Detects the format (or uses options.format), reads the dataset, applies the camera override
// and the frame selection. Throws lcv::InputError (unknown layout, missing or bad files, no
// frame selected).
std::unique_ptr<Dataset> OpenDataset(const std::string& path, const DatasetOptions& options = {});

// The format OpenDataset would use for path ("kitti", "tum", "tum-mono", "euroc", "lcv",
// "images", "video"), or empty when none fits.
std::optional<std::string> DetectDatasetFormat(const std::string& path);

}  // namespace lcv::mapping
