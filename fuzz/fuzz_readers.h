#pragma once
// The readers of untrusted input, one entry point each, shared by the libFuzzer targets
// (fuzz/fuzz_target.cc, -DLCV_FUZZ=ON) and the ctest smoke test that replays the committed
// corpus (tests/fuzz/corpus_replay_test.cc). The contract every reader must keep on any bytes:
// return normally, or throw lcv::InputError whose message names the input (its scratch path,
// "fuzz-input", or "--fail-on" for rule strings). Anything else escaping (std::logic_error from
// an LCV_CHECK, std::bad_alloc, a crash, a hang) is a bug.
//
// Path-based readers get the bytes written into a small fixed scene under scratch_dir (made by
// PrepareScratch: two 32x24 images and a camera file per dataset layout).
// Header-only so that the fuzz targets need no library of their own. Not thread-safe: one
// scratch_dir per process.

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "mapping/io/camera_file.h"
#include "mapping/io/colmap.h"
#include "mapping/io/dataset.h"
#include "mapping/io/map_file.h"
#include "mapping/io/trajectory.h"
#include "mapping/line_cloud.h"
#include "privacy/audit.h"
#include "slam/util/error.h"

namespace lcv::fuzz {

// The corpus folder names, one per reader.
inline const std::vector<std::string>& ReaderNames() {
  static const std::vector<std::string> names = {
      "map", "camera", "trajectory", "times", "tum_index", "kitti_calib", "colmap", "audit_rules"};
  return names;
}

namespace internal {

inline void WriteBytes(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

inline void WriteImages(const std::filesystem::path& dir, const std::vector<std::string>& names) {
  std::filesystem::create_directories(dir);
  for (std::size_t i = 0; i < names.size(); ++i) {
    cv::imwrite((dir / names[i]).string(), cv::Mat(24, 32, CV_8UC1, cv::Scalar(40.0 * (i + 1))));
  }
}

constexpr const char* kCameraYaml =
    "Camera.name: small\nCamera.model: perspective\nCamera.fx: 30\nCamera.fy: 30\n"
    "Camera.cx: 15.5\nCamera.cy: 11.5\nCamera.cols: 32\nCamera.rows: 24\nCamera.fps: 20\n";

// A map the reader accepted must survive what commands do with it: re-serialization in both
// encodings reads back, and publishing it as a line cloud gives a valid map.
inline void ExerciseAcceptedMap(const slam::Map& map) {
  for (const mapping::MapEncoding encoding :
       {mapping::MapEncoding::kJson, mapping::MapEncoding::kMessagePack}) {
    mapping::ParseMap(mapping::SerializeMap(map, encoding), "fuzz-roundtrip");
  }
  mapping::ValidateMap(mapping::ConvertToLineCloud(map, mapping::LineCloudOptions{}),
                       "fuzz-line-cloud");
}

// "=== cameras.txt" lines split one corpus file into the three files of a COLMAP text model.
inline void WriteColmapModel(const std::filesystem::path& dir, const std::string& bytes) {
  std::filesystem::create_directories(dir);
  const char* names[3] = {"cameras.txt", "images.txt", "points3D.txt"};
  std::string parts[3];
  int current = 0;
  std::size_t at = 0;
  while (at < bytes.size()) {
    std::size_t end = bytes.find('\n', at);
    end = end == std::string::npos ? bytes.size() : end + 1;
    const std::string line = bytes.substr(at, end - at);
    bool header = false;
    for (int k = 0; k < 3; ++k) {
      if (line.rfind(std::string("=== ") + names[k], 0) == 0) {
        current = k;
        header = true;
      }
    }
    if (!header) parts[current] += line;
    at = end;
  }
  for (int k = 0; k < 3; ++k) WriteBytes(dir / names[k], parts[k]);
}

}  // namespace internal

// True when an InputError message names the input it refused (see the contract above).
inline bool NamesInput(const std::string& message, const std::string& scratch_dir) {
  return message.find(scratch_dir) != std::string::npos || message.rfind("fuzz-", 0) == 0 ||
         message.rfind("--fail-on", 0) == 0;
}

// Builds the fixed parts of the scratch scenes (idempotent).
inline void PrepareScratch(const std::string& scratch_dir) {
  namespace fs = std::filesystem;
  const fs::path root(scratch_dir);
  fs::create_directories(root);
  internal::WriteImages(root / "tum" / "rgb", {"0.png", "1.png"});
  internal::WriteBytes(root / "tum" / "camera.yaml", internal::kCameraYaml);
  internal::WriteImages(root / "kitti" / "image_0", {"000000.png", "000001.png"});
}

// Feeds bytes to the named reader (see ReaderNames). Throws lcv::InputError for a refused input,
// std::invalid_argument for an unknown reader name; never anything else unless a reader has a bug.
inline void ReadOne(const std::string& reader, const std::string& bytes,
                    const std::string& scratch_dir) {
  namespace fs = std::filesystem;
  const fs::path root(scratch_dir);
  if (reader == "map") {
    internal::ExerciseAcceptedMap(mapping::ParseMap(bytes, "fuzz-input"));
  } else if (reader == "camera") {
    mapping::ParseCameraFile(bytes, "fuzz-input", mapping::CameraFileOptions{});
  } else if (reader == "trajectory") {
    const std::string path = (root / "trajectory.txt").string();
    internal::WriteBytes(path, bytes);
    mapping::ReadTrajectory(path, mapping::DetectTrajectoryFormat(path));
  } else if (reader == "times") {
    const std::string path = (root / "times.txt").string();
    internal::WriteBytes(path, bytes);
    mapping::ReadTimesFile(path);
  } else if (reader == "tum_index") {
    internal::WriteBytes(root / "tum" / "rgb.txt", bytes);
    mapping::DatasetOptions options;
    options.format = "tum";
    mapping::OpenDataset((root / "tum").string(), options);
  } else if (reader == "kitti_calib") {
    internal::WriteBytes(root / "kitti" / "calib.txt", bytes);
    mapping::DatasetOptions options;
    options.format = "kitti";
    mapping::OpenDataset((root / "kitti").string(), options);
  } else if (reader == "colmap") {
    const fs::path dir = root / "colmap";
    internal::WriteColmapModel(dir, bytes);
    internal::ExerciseAcceptedMap(mapping::ReadColmapTextModel(dir.string()));
  } else if (reader == "audit_rules") {
    privacy::ParseFailRules(bytes);
  } else {
    throw std::invalid_argument("unknown reader '" + reader + "'");
  }
}

}  // namespace lcv::fuzz
