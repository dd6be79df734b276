// The lcv_media plugin (build/lcv_media.so): OpenCV's imgcodecs and videoio behind
// mapping/io/media_backend.h. Loaded by mapping/io/media.cc on the first image or video, so that
// commands which never decode one (map info, audit, ...) do not load GDAL, GStreamer, FFmpeg and
// the ~240 other libraries these two modules link.

#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "mapping/io/media_backend.h"

namespace lcv::mapping::internal {
namespace {

class OpenCvVideoReader : public VideoReader {
 public:
  explicit OpenCvVideoReader(cv::VideoCapture capture) : capture_(std::move(capture)) {}
  bool Grab() override { return capture_.grab(); }
  bool Read(cv::Mat* frame) override { return capture_.read(*frame); }
  int Width() const override { return static_cast<int>(capture_.get(cv::CAP_PROP_FRAME_WIDTH)); }
  int Height() const override { return static_cast<int>(capture_.get(cv::CAP_PROP_FRAME_HEIGHT)); }
  double FrameCount() const override { return capture_.get(cv::CAP_PROP_FRAME_COUNT); }
  double Fps() const override { return capture_.get(cv::CAP_PROP_FPS); }

 private:
  cv::VideoCapture capture_;
};

class OpenCvVideoWriter : public VideoWriter {
 public:
  explicit OpenCvVideoWriter(std::unique_ptr<cv::VideoWriter> writer) : writer_(std::move(writer)) {}
  void Write(const cv::Mat& frame) override { writer_->write(frame); }

 private:
  std::unique_ptr<cv::VideoWriter> writer_;
};

int ImreadFlags(ImageMode mode) {
  switch (mode) {
    case ImageMode::kGray: return cv::IMREAD_GRAYSCALE;
    case ImageMode::kColor: return cv::IMREAD_COLOR;
    case ImageMode::kUnchanged: return cv::IMREAD_UNCHANGED;
  }
  return cv::IMREAD_UNCHANGED;
}

class OpenCvMediaBackend : public MediaBackend {
 public:
  cv::Mat ReadImage(const std::string& path, ImageMode mode) const override {
    return cv::imread(path, ImreadFlags(mode));
  }
  bool EncodePng(const cv::Mat& image, int compression, std::vector<unsigned char>* bytes) const override {
    return cv::imencode(".png", image, *bytes, {cv::IMWRITE_PNG_COMPRESSION, compression});
  }
  std::unique_ptr<VideoReader> OpenVideo(const std::string& path) const override {
    cv::VideoCapture capture;
    capture.open(path, cv::CAP_ANY);
    if (!capture.isOpened()) return nullptr;
    return std::make_unique<OpenCvVideoReader>(std::move(capture));
  }
  std::unique_ptr<VideoWriter> CreateVideo(const std::string& path, const std::string& fourcc,
                                           double fps, cv::Size size) const override {
    if (fourcc.size() != 4) return nullptr;
    auto writer = std::make_unique<cv::VideoWriter>();
    if (!writer->open(path, cv::VideoWriter::fourcc(fourcc[0], fourcc[1], fourcc[2], fourcc[3]), fps,
                      size)) {
      return nullptr;
    }
    return std::make_unique<OpenCvVideoWriter>(std::move(writer));
  }
};

}  // namespace
}  // namespace lcv::mapping::internal

extern "C" __attribute__((visibility("default"))) const lcv::mapping::internal::MediaBackend*
lcv_media_backend(int* version) {
  static const lcv::mapping::internal::OpenCvMediaBackend backend;
  *version = lcv::mapping::internal::kMediaBackendVersion;
  return &backend;
}
