// EuRoC MAV layout (ASL format): <seq>/mav0/cam0/data.csv ("timestamp_ns,filename"),
// mav0/cam0/data/<filename>, mav0/cam0/sensor.yaml (intrinsics, distortion, resolution,
// rate_hz, T_BS), ground truth in mav0/state_groundtruth_estimate0/data.csv (pose of the body
// (IMU) frame S in the world R: timestamp_ns, p_RS_R xyz, q_RS wxyz, ...).

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include <nlohmann/json.hpp>

#include "mapping/io/atomic_file.h"
#include "mapping/io/dataset_readers.h"
#include "mapping/io/yaml_subset.h"
#include "slam/util/error.h"

namespace lcv::mapping::internal {
namespace {

using nlohmann::json;

constexpr double kMaxGroundTruthTimeDifferenceS = 0.02;

// The comma-separated fields of the data lines of an ASL csv file, with their line numbers.
struct CsvLine {
  int number;
  std::vector<std::string> fields;
};

std::vector<CsvLine> ReadCsv(const std::string& path) {
  std::istringstream in(ReadTextFile(path));
  std::vector<CsvLine> lines;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    CsvLine csv{number, {}};
    std::istringstream fields(line);
    std::string field;
    while (std::getline(fields, field, ',')) {
      const std::size_t b = field.find_first_not_of(" \t");
      const std::size_t e = field.find_last_not_of(" \t");
      csv.fields.push_back(b == std::string::npos ? "" : field.substr(b, e - b + 1));
    }
    lines.push_back(std::move(csv));
  }
  return lines;
}

// Nanosecond timestamp -> seconds.
double ParseNanoseconds(const std::string& text, const std::string& path, int line) {
  bool digits = !text.empty();
  for (const char c : text) digits &= c >= '0' && c <= '9';
  errno = 0;
  const unsigned long long ns = digits ? std::strtoull(text.c_str(), nullptr, 10) : 0;
  if (!digits || errno != 0) {
    throw InputError(path, "line " + std::to_string(line) + ": '" + text +
                               "' is not a timestamp in nanoseconds");
  }
  // Whole seconds and the rest separately, so that the division keeps the nanoseconds.
  return static_cast<double>(ns / 1000000000ULL) + static_cast<double>(ns % 1000000000ULL) * 1e-9;
}

double ParseNumber(const std::string& text, const std::string& path, int line) {
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || errno != 0 || !std::isfinite(v)) {
    throw InputError(path, "line " + std::to_string(line) + ": '" + text + "' is not a number");
  }
  return v;
}

std::vector<double> NumberList(const json& root, const std::string& key, std::size_t count,
                               const std::string& path) {
  const auto it = root.find(key);
  if (it == root.end()) throw InputError(path, key + ": missing");
  if (!it->is_array() || it->size() != count) {
    throw InputError(path, key + ": expected a list of " + std::to_string(count) + " numbers, got " +
                               it->dump());
  }
  std::vector<double> values;
  for (const json& v : *it) {
    if (!v.is_number()) throw InputError(path, key + ": '" + v.dump(-1, ' ', false, json::error_handler_t::replace) + "' is not a number");
    values.push_back(v.get<double>());
  }
  return values;
}

// The camera and body_from_cam (T_BS) of sensor.yaml.
slam::CameraParams ReadSensorYaml(const std::string& path, slam::Rigid3d* body_from_cam) {
  const json root = ParseYamlSubset(ReadTextFile(path), path);
  if (!root.is_object()) throw InputError(path, "expected a mapping");
  slam::CameraParams camera;
  camera.name = "EuRoC " + (root.contains("comment") && root["comment"].is_string()
                                ? root["comment"].get<std::string>()
                                : std::string("cam0"));
  const std::string model = root.value("camera_model", std::string());
  if (model != "pinhole") {
    throw InputError(path, "camera_model: '" + model + "' is not supported (expected pinhole)");
  }
  const std::vector<double> k = NumberList(root, "intrinsics", 4, path);
  camera.fx = k[0];
  camera.fy = k[1];
  camera.cx = k[2];
  camera.cy = k[3];
  const std::vector<double> size = NumberList(root, "resolution", 2, path);
  camera.cols = static_cast<int>(size[0]);
  camera.rows = static_cast<int>(size[1]);
  if (root.contains("rate_hz") && root["rate_hz"].is_number()) camera.fps = root["rate_hz"];
  const std::vector<double> d = NumberList(root, "distortion_coefficients", 4, path);
  const std::string distortion = root.value("distortion_model", std::string());
  if (distortion == "radial-tangential" || distortion == "radtan") {
    camera.model = slam::CameraModel::kPerspective;
    camera.distortion = {d[0], d[1], d[2], d[3], 0.0};
  } else if (distortion == "equidistant") {
    camera.model = slam::CameraModel::kFisheye;
    camera.distortion = {d[0], d[1], d[2], d[3], 0.0};
  } else {
    throw InputError(path, "distortion_model: '" + distortion +
                               "' is not supported (expected radial-tangential or equidistant)");
  }
  *body_from_cam = slam::Rigid3d();
  if (root.contains("T_BS")) {
    const json& t = root["T_BS"];
    if (!t.is_object() || !t.contains("data")) throw InputError(path, "T_BS: expected rows, cols, data");
    const std::vector<double> m = NumberList(t, "data", 16, path);
    Eigen::Matrix<double, 3, 4> body_from_cam_matrix;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) body_from_cam_matrix(r, c) = m[4 * r + c];
    }
    const Eigen::Matrix3d R = body_from_cam_matrix.leftCols<3>();
    if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-3 || R.determinant() < 0) {
      throw InputError(path, "T_BS: the 3x3 part is not a rotation");
    }
    *body_from_cam = slam::Rigid3d::FromMatrix(body_from_cam_matrix);
  }
  return camera;
}

}  // namespace

ReaderResult ReadEuroc(const std::string& path, const DatasetOptions& options) {
  const std::string mav0 = IsDirectory(JoinPath(path, "mav0")) ? JoinPath(path, "mav0") : path;
  const std::string cam0 = JoinPath(mav0, "cam0");
  const std::string list_path = JoinPath(cam0, "data.csv");
  std::vector<DatasetFrame> frames;
  for (const CsvLine& line : ReadCsv(list_path)) {
    if (line.fields.size() != 2) {
      throw InputError(list_path, "line " + std::to_string(line.number) +
                                      ": expected 'timestamp [ns],filename'");
    }
    DatasetFrame frame;
    frame.index = frames.size();
    frame.timestamp = ParseNanoseconds(line.fields[0], list_path, line.number);
    frame.image_path = JoinPath(JoinPath(cam0, "data"), line.fields[1]);
    frames.push_back(std::move(frame));
  }
  if (frames.empty()) throw InputError(list_path, "no images listed");
  CheckIncreasingTimestamps(frames, list_path);

  ReaderResult result;
  slam::CameraParams camera;
  slam::Rigid3d body_from_cam;
  const std::string sensor_path = JoinPath(cam0, "sensor.yaml");
  if (IsFile(sensor_path)) {
    camera = ReadSensorYaml(sensor_path, &body_from_cam);
    result.camera_source = sensor_path;
  } else if (options.camera_file) {
    result.camera_source = *options.camera_file;
  } else {
    throw InputError(sensor_path, "missing (EuRoC camera intrinsics); or pass --camera FILE");
  }

  const std::string gt_path = JoinPath(mav0, "state_groundtruth_estimate0/data.csv");
  if (IsFile(gt_path)) {
    Trajectory gt;
    for (const CsvLine& line : ReadCsv(gt_path)) {
      if (line.fields.size() < 8) {
        throw InputError(gt_path, "line " + std::to_string(line.number) +
                                      ": expected timestamp, p_RS_R xyz, q_RS wxyz, ...");
      }
      double v[8];
      v[0] = ParseNanoseconds(line.fields[0], gt_path, line.number);
      for (int i = 1; i < 8; ++i) v[i] = ParseNumber(line.fields[i], gt_path, line.number);
      Eigen::Quaterniond world_from_body_rotation(v[4], v[5], v[6], v[7]);
      if (std::fabs(world_from_body_rotation.norm() - 1.0) > 0.05) {
        throw InputError(gt_path, "line " + std::to_string(line.number) + ": quaternion norm is not 1");
      }
      world_from_body_rotation.normalize();
      const slam::Rigid3d world_from_body(world_from_body_rotation, Eigen::Vector3d(v[1], v[2], v[3]));
      if (!gt.poses.empty() && !(v[0] > gt.poses.back().timestamp)) {
        throw InputError(gt_path, "line " + std::to_string(line.number) + ": timestamps do not increase");
      }
      gt.poses.push_back({v[0], (world_from_body * body_from_cam).Inverse()});
    }
    AssignGroundTruthByTimestamp(gt, kMaxGroundTruthTimeDifferenceS, &frames);
  }
  result.dataset = std::make_unique<Dataset>("euroc", path, camera, std::move(frames));
  return result;
}

}  // namespace lcv::mapping::internal
