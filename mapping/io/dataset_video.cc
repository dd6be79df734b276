// A video file read through cv::VideoCapture, with a camera file (--camera, or camera.yaml /
// camera.json beside the video). Frames are decoded in order; going back reopens the file.
// Timestamps are index / fps of the container (of the camera file when the container has none).

#include <filesystem>

#include <opencv2/imgproc.hpp>

#include "mapping/io/dataset_readers.h"
#include "mapping/io/media.h"
#include "slam/util/error.h"

namespace lcv::mapping::internal {
namespace {

namespace fs = std::filesystem;

std::unique_ptr<VideoReader> OpenCapture(const std::string& path) {
  std::unique_ptr<VideoReader> capture;
  try {
    capture = OpenVideoFile(path);
  } catch (const cv::Exception& e) {
    throw InputError(path, std::string("cannot open video: ") + e.what());
  }
  if (!capture) throw InputError(path, "cannot open video (unsupported codec or not a video)");
  return capture;
}

class VideoDataset : public Dataset {
 public:
  VideoDataset(const std::string& path, const slam::CameraParams& camera,
               std::vector<DatasetFrame> frames)
      : Dataset("video", path, camera, std::move(frames)) {}

  cv::Mat LoadImage(std::size_t i, bool grayscale) const override {
    LCV_CHECK(i < frames_.size()) << i << " >= " << frames_.size();
    const std::size_t wanted = frames_[i].index;
    if (!capture_ || wanted < next_frame_) {
      capture_ = OpenCapture(path_);
      next_frame_ = 0;
    }
    cv::Mat frame;
    try {
      while (next_frame_ < wanted) {
        if (!capture_->Grab()) break;
        ++next_frame_;
      }
      if (next_frame_ == wanted && capture_->Read(&frame)) ++next_frame_;
    } catch (const cv::Exception& e) {
      throw InputError(path_, "frame " + std::to_string(wanted) + ": cannot decode: " + e.what());
    }
    if (frame.empty()) {
      // Force a reopen next time: the decoder position is unknown now.
      capture_.reset();
      throw InputError(path_, "frame " + std::to_string(wanted) + ": cannot read (the video has " +
                                  std::to_string(next_frame_) + " readable frames)");
    }
    cv::Mat out;
    if (frame.channels() == 1) {
      out = grayscale ? frame : cv::Mat();
      if (!grayscale) cv::cvtColor(frame, out, cv::COLOR_GRAY2BGR);
    } else if (grayscale) {
      cv::cvtColor(frame, out, frame.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
    } else {
      out = frame.channels() == 4 ? cv::Mat() : frame;
      if (frame.channels() == 4) cv::cvtColor(frame, out, cv::COLOR_BGRA2BGR);
    }
    CheckImageSize(out, path_ + " frame " + std::to_string(wanted));
    return out;
  }

 private:
  mutable std::unique_ptr<VideoReader> capture_;
  mutable std::size_t next_frame_ = 0;
};

}  // namespace

ReaderResult ReadVideo(const std::string& path, const DatasetOptions& options) {
  ReaderResult result;
  const std::string dir = fs::path(path).parent_path().string();
  const slam::CameraParams camera =
      RequireCameraFile(dir.empty() ? "." : dir, path, options, &result.camera_source);

  const std::unique_ptr<VideoReader> capture = OpenCapture(path);
  result.image_cols = capture->Width();
  result.image_rows = capture->Height();
  double count = capture->FrameCount();
  if (!(count > 0)) {
    // Some containers do not state their length: count by demuxing.
    count = 0;
    while (capture->Grab()) ++count;
  }
  if (count < 1) throw InputError(path, "no frames");
  if (result.image_cols <= 0 || result.image_rows <= 0) {
    cv::Mat first;
    if (!OpenCapture(path)->Read(&first) || first.empty()) throw InputError(path, "cannot read frame 0");
    result.image_cols = first.cols;
    result.image_rows = first.rows;
  }
  // Timestamps from the container's frame rate; the camera file's fps when it states none.
  const double video_fps = capture->Fps();
  const double fps = video_fps > 0 && video_fps < 1000 ? video_fps : camera.fps;
  std::vector<DatasetFrame> frames(static_cast<std::size_t>(count));
  for (std::size_t i = 0; i < frames.size(); ++i) {
    frames[i].index = i;
    frames[i].timestamp = static_cast<double>(i) / fps;
  }
  result.dataset = std::make_unique<VideoDataset>(path, camera, std::move(frames));
  return result;
}

}  // namespace lcv::mapping::internal
