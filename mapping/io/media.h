#pragma once
// Image files and videos: decoding dataset images, encoding PNGs, reading and writing videos.
//
// OpenCV's imgcodecs and videoio do the work, but they are not linked into lcv: they live in the
// lcv_media plugin (build/lcv_media.so, mapping/io/media_plugin/), loaded on the first call of any
// function here. Linked, they and what they pull in (GDAL, GStreamer, FFmpeg, ...) would cost every
// command ~70 MB of memory and ~0.2 s at start, including the commands that only read an
// untrusted map file (README "Hardening"). The plugin is looked up beside the executable, then in
// the build folder (mapping/CMakeLists.txt), so build/lcv and the test executables work from any
// working directory.
//
// Failure: a missing or broken plugin throws lcv::InputError naming the plugin file(s) tried.
// Otherwise the semantics are OpenCV's (below).
// Thread safety: every function may be called from any thread; one VideoReader or VideoWriter
// by one thread at a time.

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace lcv::mapping {

enum class ImageMode {
  kGray,       // 8-bit, 1 channel (cv::IMREAD_GRAYSCALE)
  kColor,      // 8-bit BGR (cv::IMREAD_COLOR)
  kUnchanged,  // as stored (cv::IMREAD_UNCHANGED): depth and channels of the file
};

// Decodes an image file (PNG, JPEG, ... whatever cv::imread reads). Returns an empty Mat when the
// file is missing or not a decodable image; throws lcv::InputError naming `path` when the decoder
// throws.
cv::Mat ReadImageFile(const std::string& path, ImageMode mode);

// The image encoded as PNG (zlib level 0..9). Throws lcv::InputError naming `destination` (the
// file the bytes are meant for) when it cannot be encoded.
std::vector<unsigned char> EncodePng(const cv::Mat& image, int compression, const std::string& destination);

// A video being decoded frame by frame in order (cv::VideoCapture).
class VideoReader {
 public:
  virtual ~VideoReader() = default;
  virtual bool Grab() = 0;                // skips one frame; false at the end
  virtual bool Read(cv::Mat* frame) = 0;  // decodes the next frame; false at the end
  // What the container states; <= 0 when it states nothing.
  virtual int Width() const = 0;
  virtual int Height() const = 0;
  virtual double FrameCount() const = 0;
  virtual double Fps() const = 0;
};

// Opens a video file; null when it cannot be opened (unsupported codec, not a video). cv::Exception
// of the decoder propagates.
std::unique_ptr<VideoReader> OpenVideoFile(const std::string& path);

// A video being written (cv::VideoWriter).
class VideoWriter {
 public:
  virtual ~VideoWriter() = default;
  virtual void Write(const cv::Mat& frame) = 0;  // 8-bit BGR, of the size given at creation
};

// Creates a video file with a codec given by its 4-character code ("mp4v", "MJPG"); null when no
// writer opens (codec unavailable, folder missing).
std::unique_ptr<VideoWriter> CreateVideoFile(const std::string& path, const std::string& fourcc,
                                             double fps, cv::Size size);

}  // namespace lcv::mapping
