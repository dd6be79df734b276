#include "mapping/io/media.h"

#include <filesystem>

#include "mapping/io/media_backend.h"
#include "mapping/io/shared_library.h"
#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

const internal::MediaBackend& LoadBackend() {
  // Beside the executable first (build/lcv, an installed tree), then the build folder, for the
  // test and benchmark executables in its subfolders.
  std::vector<std::string> candidates;
  const std::string exe_dir = ExecutableDir();
  if (!exe_dir.empty()) candidates.push_back(exe_dir + "/" + internal::kMediaPluginFile);
  const std::string build_path = std::string(LCV_PLUGIN_BUILD_DIR) + "/" + internal::kMediaPluginFile;
  if (candidates.empty() || std::filesystem::path(candidates.front()) != build_path) {
    candidates.push_back(build_path);
  }
  const SharedLibrary library =
      SharedLibrary::Open(candidates, "to read and write images and videos (OpenCV imgcodecs, videoio)");
  using Entry = const internal::MediaBackend* (*)(int*);
  const auto entry = reinterpret_cast<Entry>(library.Symbol(internal::kMediaBackendSymbol));
  int version = 0;
  const internal::MediaBackend* backend = entry(&version);
  if (version != internal::kMediaBackendVersion || !backend) {
    throw InputError(library.path(), "plugin version " + std::to_string(version) + ", this lcv needs " +
                                         std::to_string(internal::kMediaBackendVersion) +
                                         " (rebuild the plugin with the program)");
  }
  return *backend;
}

const internal::MediaBackend& Backend() {
  static const internal::MediaBackend& backend = LoadBackend();  // thread-safe initialization
  return backend;
}

}  // namespace

cv::Mat ReadImageFile(const std::string& path, ImageMode mode) {
  const internal::MediaBackend& backend = Backend();
  try {
    return backend.ReadImage(path, mode);
  } catch (const cv::Exception& e) {
    throw InputError(path, std::string("cannot decode image: ") + e.what());
  }
}

std::vector<unsigned char> EncodePng(const cv::Mat& image, int compression, const std::string& destination) {
  std::vector<unsigned char> bytes;
  bool encoded = false;
  try {
    encoded = Backend().EncodePng(image, compression, &bytes);
  } catch (const cv::Exception& e) {
    throw InputError(destination, std::string("cannot encode the image as PNG: ") + e.what());
  }
  if (!encoded) throw InputError(destination, "cannot encode the image as PNG");
  return bytes;
}

std::unique_ptr<VideoReader> OpenVideoFile(const std::string& path) { return Backend().OpenVideo(path); }

std::unique_ptr<VideoWriter> CreateVideoFile(const std::string& path, const std::string& fourcc, double fps,
                                             cv::Size size) {
  return Backend().CreateVideo(path, fourcc, fps, size);
}

}  // namespace lcv::mapping
