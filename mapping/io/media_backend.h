#pragma once
// INTERNAL: the interface between lcv_mapping_io (mapping/io/media.cc) and the lcv_media plugin
// (mapping/io/media_plugin/media_plugin.cc), the only code that links OpenCV's imgcodecs and
// videoio. Use mapping/io/media.h instead.
//
// Both sides are built from this header by the same compiler in the same build, so C++ classes
// cross the dlopen boundary; kMediaBackendVersion changes with any change of this header or of
// the classes of media.h, so that a stale plugin is refused instead of called through a wrong
// vtable. The semantics are OpenCV's: an undecodable file gives an empty image or a null
// reader; cv::Exception propagates to the caller.

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "mapping/io/media.h"

namespace lcv::mapping::internal {

inline constexpr int kMediaBackendVersion = 1;
// extern "C" const MediaBackend* lcv_media_backend(int* version): the plugin's only export.
inline constexpr const char* kMediaBackendSymbol = "lcv_media_backend";
// The plugin's file name (a CMake MODULE library without the "lib" prefix).
inline constexpr const char* kMediaPluginFile = "lcv_media.so";

class MediaBackend {
 public:
  virtual ~MediaBackend() = default;
  virtual cv::Mat ReadImage(const std::string& path, ImageMode mode) const = 0;  // cv::imread
  // cv::imencode(".png", image, *bytes, {cv::IMWRITE_PNG_COMPRESSION, compression}).
  virtual bool EncodePng(const cv::Mat& image, int compression, std::vector<unsigned char>* bytes) const = 0;
  virtual std::unique_ptr<VideoReader> OpenVideo(const std::string& path) const = 0;
  virtual std::unique_ptr<VideoWriter> CreateVideo(const std::string& path, const std::string& fourcc,
                                                   double fps, cv::Size size) const = 0;
};

}  // namespace lcv::mapping::internal
