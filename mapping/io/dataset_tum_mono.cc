// TUM monoVO layout (Engel et al. 2016): <seq>/images/NNNNN.jpg|png, <seq>/times.txt ("id
// timestamp exposure_ms" per line), <seq>/camera.txt (DSO's calibration format). No ground
// truth is read (the dataset only has aligned start/end segments).
//
// camera.txt, first line: "[Model] fx fy cx cy [distortion...]" with Model one of Pinhole,
// RadTan (k1 k2 p1 p2), EquiDistant / KannalaBrandt (k1 k2 k3 k4), FOV (omega); no model name
// with 5 numbers means FOV. Second line: "width height". Intrinsics below 1 (cx, cy) are
// relative to the image size, converted as DSO does (fx * w, cx * w - 0.5). The FOV model with
// omega != 0 has no equivalent here: such a sequence needs a camera file (--camera) for
// rectified images.

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "mapping/io/atomic_file.h"
#include "mapping/io/camera_file.h"
#include "mapping/io/dataset_readers.h"
#include "slam/util/error.h"

namespace lcv::mapping::internal {
namespace {

std::vector<double> Numbers(const std::vector<std::string>& tokens, std::size_t first,
                            const std::string& path, int line) {
  std::vector<double> values;
  for (std::size_t i = first; i < tokens.size(); ++i) {
    errno = 0;
    char* end = nullptr;
    const double v = std::strtod(tokens[i].c_str(), &end);
    if (*end != '\0' || errno != 0 || !std::isfinite(v)) {
      throw InputError(path, "line " + std::to_string(line) + ": '" + tokens[i] + "' is not a number");
    }
    values.push_back(v);
  }
  return values;
}

std::vector<std::string> Tokens(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> tokens;
  std::string token;
  while (in >> token) tokens.push_back(token);
  return tokens;
}

slam::CameraParams ReadDsoCamera(const std::string& path) {
  std::istringstream in(ReadTextFile(path));
  std::string line1, line2;
  std::getline(in, line1);
  std::getline(in, line2);
  const std::vector<std::string> first = Tokens(line1);
  if (first.empty()) throw InputError(path, "line 1: expected '[Model] fx fy cx cy [distortion]'");
  const bool named = !first[0].empty() && std::isalpha(static_cast<unsigned char>(first[0][0]));
  const std::string model = named ? first[0] : "FOV";
  const std::vector<double> p = Numbers(first, named ? 1 : 0, path, 1);
  const std::vector<double> size = Numbers(Tokens(line2), 0, path, 2);
  if (size.size() != 2 || size[0] < 1 || size[1] < 1) {
    throw InputError(path, "line 2: expected 'width height'");
  }
  std::size_t expected = 0;
  slam::CameraParams camera;
  camera.name = "TUM monoVO";
  if (model == "Pinhole") {
    expected = p.size() == 5 ? 5 : 4;  // DSO writes a trailing 0
  } else if (model == "FOV") {
    expected = 5;
  } else if (model == "RadTan") {
    expected = 8;
  } else if (model == "EquiDistant" || model == "KannalaBrandt") {
    expected = 8;
    camera.model = slam::CameraModel::kFisheye;
  } else {
    throw InputError(path, "line 1: unknown camera model '" + model +
                               "' (expected Pinhole, RadTan, EquiDistant, KannalaBrandt or FOV)");
  }
  if (p.size() != expected) {
    throw InputError(path, "line 1: " + model + " needs " + std::to_string(expected) +
                               " numbers, got " + std::to_string(p.size()));
  }
  if (model == "FOV" && p[4] != 0.0) {
    throw InputError(path, "line 1: the FOV (ATAN) distortion model (omega " +
                               FormatDoubleExact(p[4]) +
                               ") is not supported: pass a camera file (--camera) for rectified "
                               "images");
  }
  const double w = size[0], h = size[1];
  const bool relative = p[2] < 1.0 && p[3] < 1.0;
  camera.fx = relative ? p[0] * w : p[0];
  camera.fy = relative ? p[1] * h : p[1];
  camera.cx = relative ? p[2] * w - 0.5 : p[2];
  camera.cy = relative ? p[3] * h - 0.5 : p[3];
  if (expected == 8) {
    for (int i = 0; i < 4; ++i) camera.distortion[i] = p[4 + i];
  }
  camera.cols = static_cast<int>(w);
  camera.rows = static_cast<int>(h);
  return camera;
}

}  // namespace

ReaderResult ReadTumMono(const std::string& path, const DatasetOptions& options) {
  const std::string image_dir = JoinPath(path, "images");
  const std::vector<std::string> images = ListImageFiles(image_dir);
  if (images.empty()) {
    throw InputError(image_dir, IsFile(JoinPath(path, "images.zip"))
                                    ? "no images (unzip images.zip into images/ first)"
                                    : "no images");
  }
  const std::string times_path = JoinPath(path, "times.txt");
  std::istringstream in(ReadTextFile(times_path));
  std::vector<DatasetFrame> frames;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    const std::vector<std::string> tokens = Tokens(line);
    if (tokens.empty() || tokens[0][0] == '#') continue;
    if (tokens.size() < 2) {
      throw InputError(times_path, "line " + std::to_string(number) +
                                       ": expected 'id timestamp [exposure_ms]'");
    }
    DatasetFrame frame;
    frame.index = frames.size();
    frame.timestamp = Numbers({tokens[1]}, 0, times_path, number)[0];
    frames.push_back(std::move(frame));
  }
  if (frames.size() != images.size()) {
    throw InputError(times_path, std::to_string(frames.size()) + " timestamps for " +
                                     std::to_string(images.size()) + " images in images/");
  }
  for (std::size_t i = 0; i < frames.size(); ++i) frames[i].image_path = images[i];

  ReaderResult result;
  slam::CameraParams camera;
  if (options.camera_file) {
    result.camera_source = *options.camera_file;
  } else {
    result.camera_source = JoinPath(path, "camera.txt");
    camera = ReadDsoCamera(result.camera_source);
    const double span = frames.back().timestamp - frames.front().timestamp;
    if (frames.size() > 1 && span > 0) camera.fps = (frames.size() - 1) / span;
  }
  result.dataset = std::make_unique<Dataset>("tum-mono", path, camera, std::move(frames));
  return result;
}

}  // namespace lcv::mapping::internal
