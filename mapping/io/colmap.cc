#include "mapping/io/colmap.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <vector>

#include "mapping/io/atomic_file.h"
#include "mapping/io/map_file.h"
#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

using slam::Id;

// COLMAP's pixel origin is the corner of the top-left pixel, ours its centre.
constexpr double kPixelShift = -0.5;

// The non-comment lines of a text file with their 1-based line numbers. Blank lines are kept:
// in images.txt an empty line is an image without 2D points.
struct TextLine {
  int number;
  std::string text;
};

std::vector<TextLine> ReadLines(const std::string& path) {
  std::string bytes;
  try {
    bytes = ReadTextFile(path);
  } catch (const InputError& e) {
    throw InputError(std::string(e.what()) +
                     " (a COLMAP text model needs cameras.txt, images.txt, points3D.txt)");
  }
  std::istringstream in(bytes);
  std::vector<TextLine> lines;
  std::string text;
  int number = 0;
  while (std::getline(in, text)) {
    ++number;
    if (!text.empty() && text.back() == '\r') text.pop_back();
    if (!text.empty() && text[0] == '#') continue;
    lines.push_back({number, std::move(text)});
  }
  return lines;
}

bool IsBlank(const std::string& s) {
  return std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isspace(c); });
}

std::vector<std::string> Split(const std::string& s) {
  std::istringstream in(s);
  std::vector<std::string> tokens;
  std::string token;
  while (in >> token) tokens.push_back(std::move(token));
  return tokens;
}

class LineParser {
 public:
  LineParser(const std::string& path, int line) : path_(path), line_(line) {}

  [[noreturn]] void Fail(const std::string& what) const {
    throw InputError(path_ + ":" + std::to_string(line_), what);
  }
  double Number(const std::string& token, const char* field) const {
    errno = 0;
    char* end = nullptr;
    const double value = std::strtod(token.c_str(), &end);
    if (token.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(value)) {
      Fail(std::string(field) + ": '" + token + "' is not a finite number");
    }
    return value;
  }
  std::int64_t Integer(const std::string& token, const char* field) const {
    errno = 0;
    char* end = nullptr;
    const long long value = std::strtoll(token.c_str(), &end, 10);
    if (token.empty() || *end != '\0' || errno == ERANGE) {
      Fail(std::string(field) + ": '" + token + "' is not an integer");
    }
    return value;
  }
  // COLMAP ids: positive here (0 is never written by COLMAP and would clash with offsets' logic
  // only in degenerate cases; refusing it keeps the id arithmetic simple).
  std::uint64_t PositiveId(const std::string& token, const char* field) const {
    const std::int64_t value = Integer(token, field);
    if (value <= 0 || value > (std::int64_t(1) << 48)) {
      Fail(std::string(field) + ": " + token + " is not an id in [1, 2^48]");
    }
    return static_cast<std::uint64_t>(value);
  }

 private:
  const std::string& path_;
  int line_;
};

slam::CameraParams ParseCamera(const LineParser& p, const std::vector<std::string>& t) {
  // CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]
  if (t.size() < 4)
    p.Fail("expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[], got " + std::to_string(t.size()) +
           " fields");
  const std::string& model = t[1];
  struct Layout {
    const char* name;
    int num_params;
  };
  static const Layout kSupported[] = {{"SIMPLE_PINHOLE", 3}, {"PINHOLE", 4}, {"SIMPLE_RADIAL", 4},
                                      {"RADIAL", 5},         {"OPENCV", 8},  {"FULL_OPENCV", 12},
                                      {"OPENCV_FISHEYE", 8}};
  const Layout* layout = nullptr;
  for (const Layout& l : kSupported) {
    if (model == l.name) layout = &l;
  }
  if (!layout) {
    p.Fail("camera model " + model +
           " is not supported (supported: SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV, "
           "FULL_OPENCV with k4 = k5 = k6 = 0, OPENCV_FISHEYE)");
  }
  if (static_cast<int>(t.size()) != 4 + layout->num_params) {
    p.Fail("camera model " + model + " has " + std::to_string(layout->num_params) +
           " parameters, got " + std::to_string(static_cast<int>(t.size()) - 4));
  }
  std::vector<double> k(layout->num_params);
  for (int i = 0; i < layout->num_params; ++i) k[i] = p.Number(t[4 + i], "PARAMS");
  slam::CameraParams c;
  c.name = "COLMAP camera " + t[0] + " (" + model + ")";
  c.model = slam::CameraModel::kPerspective;
  const std::int64_t width = p.Integer(t[2], "WIDTH"), height = p.Integer(t[3], "HEIGHT");
  if (width <= 0 || height <= 0 || width > (1 << 20) || height > (1 << 20)) {
    p.Fail("image size " + t[2] + "x" + t[3] + " is not positive");
  }
  c.cols = static_cast<int>(width);
  c.rows = static_cast<int>(height);
  const bool one_focal = model == "SIMPLE_PINHOLE" || model == "SIMPLE_RADIAL" || model == "RADIAL";
  c.fx = k[0];
  c.fy = one_focal ? k[0] : k[1];
  c.cx = (one_focal ? k[1] : k[2]) + kPixelShift;
  c.cy = (one_focal ? k[2] : k[3]) + kPixelShift;
  if (model == "SIMPLE_RADIAL") {
    c.distortion = {k[3], 0, 0, 0, 0};
  } else if (model == "RADIAL") {
    c.distortion = {k[3], k[4], 0, 0, 0};
  } else if (model == "OPENCV") {
    c.distortion = {k[4], k[5], k[6], k[7], 0};
  } else if (model == "FULL_OPENCV") {
    // fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6: the rational part (k4..k6) has no counterpart here.
    if (k[9] != 0 || k[10] != 0 || k[11] != 0) {
      p.Fail("FULL_OPENCV with k4, k5, k6 != 0 (rational model) is not supported");
    }
    c.distortion = {k[4], k[5], k[6], k[7], k[8]};
  } else if (model == "OPENCV_FISHEYE") {
    c.model = slam::CameraModel::kFisheye;
    c.distortion = {k[4], k[5], k[6], k[7], 0};
  }
  if (const auto problem = c.Problem()) p.Fail("camera " + t[0] + ": " + *problem);
  return c;
}

struct ColmapImage {
  std::uint64_t id;
  std::uint64_t camera_id;
  std::string name;
  slam::Rigid3d cam_from_world;
  std::vector<slam::Keypoint> keypoints;
  std::vector<std::int64_t> point3d_ids;  // -1 for none
  int line;                               // of the image's first line
  int points_line;                        // of its POINTS2D[] line
};

struct ColmapPoint {
  std::uint64_t id;
  Eigen::Vector3d position;
  double error_px;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> track;  // (image id, point2D index)
  int line;
};

std::vector<ColmapImage> ParseImages(const std::string& path) {
  const std::vector<TextLine> lines = ReadLines(path);
  std::vector<ColmapImage> images;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (IsBlank(lines[i].text)) continue;
    const LineParser p(path, lines[i].number);
    const std::vector<std::string> t = Split(lines[i].text);
    if (t.size() < 10) {
      p.Fail("expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME, got " +
             std::to_string(t.size()) + " fields");
    }
    ColmapImage image;
    image.line = lines[i].number;
    image.points_line = lines[i].number + 1;
    image.id = p.PositiveId(t[0], "IMAGE_ID");
    const Eigen::Quaterniond q(p.Number(t[1], "QW"), p.Number(t[2], "QX"), p.Number(t[3], "QY"),
                               p.Number(t[4], "QZ"));
    if (std::abs(q.norm() - 1.0) > 1e-3) {
      p.Fail("quaternion QW QX QY QZ has norm " + std::to_string(q.norm()) + ", expected 1");
    }
    image.cam_from_world = slam::Rigid3d(
        q.normalized(),
        Eigen::Vector3d(p.Number(t[5], "TX"), p.Number(t[6], "TY"), p.Number(t[7], "TZ")));
    image.camera_id = p.PositiveId(t[8], "CAMERA_ID");
    image.name = t[9];
    for (std::size_t k = 10; k < t.size(); ++k) image.name += " " + t[k];
    // The next line (possibly empty) holds POINTS2D[] as (X, Y, POINT3D_ID).
    if (i + 1 < lines.size()) {
      ++i;
      image.points_line = lines[i].number;
      const LineParser q2(path, lines[i].number);
      const std::vector<std::string> xs = Split(lines[i].text);
      if (xs.size() % 3 != 0) {
        q2.Fail("expected POINTS2D[] as (X, Y, POINT3D_ID) triples, got " +
                std::to_string(xs.size()) + " fields");
      }
      image.keypoints.reserve(xs.size() / 3);
      image.point3d_ids.reserve(xs.size() / 3);
      for (std::size_t k = 0; k < xs.size(); k += 3) {
        slam::Keypoint kp;
        kp.x = static_cast<float>(q2.Number(xs[k], "X") + kPixelShift);
        kp.y = static_cast<float>(q2.Number(xs[k + 1], "Y") + kPixelShift);
        kp.angle_deg = -1.f;
        const std::int64_t point_id = q2.Integer(xs[k + 2], "POINT3D_ID");
        if (point_id < -1 || point_id == 0) {
          q2.Fail("POINT3D_ID " + xs[k + 2] + " is neither -1 nor a positive id");
        }
        image.keypoints.push_back(kp);
        image.point3d_ids.push_back(point_id);
      }
    }
    images.push_back(std::move(image));
  }
  return images;
}

std::vector<ColmapPoint> ParsePoints(const std::string& path) {
  std::vector<ColmapPoint> points;
  for (const TextLine& line : ReadLines(path)) {
    if (IsBlank(line.text)) continue;
    const LineParser p(path, line.number);
    const std::vector<std::string> t = Split(line.text);
    if (t.size() < 8 || (t.size() - 8) % 2 != 0) {
      p.Fail(
          "expected POINT3D_ID X Y Z R G B ERROR TRACK[] as (IMAGE_ID, POINT2D_IDX) pairs, got " +
          std::to_string(t.size()) + " fields");
    }
    ColmapPoint point;
    point.line = line.number;
    point.id = p.PositiveId(t[0], "POINT3D_ID");
    point.position = Eigen::Vector3d(p.Number(t[1], "X"), p.Number(t[2], "Y"), p.Number(t[3], "Z"));
    for (int c = 4; c < 7; ++c) {
      const std::int64_t value = p.Integer(t[c], "R G B");
      if (value < 0 || value > 255) p.Fail("colour " + t[c] + " is not in [0, 255]");
    }
    point.error_px = p.Number(t[7], "ERROR");
    if (point.error_px < 0) p.Fail("ERROR " + t[7] + " is negative");
    for (std::size_t k = 8; k < t.size(); k += 2) {
      const std::uint64_t image_id = p.PositiveId(t[k], "IMAGE_ID");
      const std::int64_t index = p.Integer(t[k + 1], "POINT2D_IDX");
      if (index < 0 || index > std::numeric_limits<std::uint32_t>::max()) {
        p.Fail("POINT2D_IDX " + t[k + 1] + " is out of range");
      }
      point.track.emplace_back(image_id, static_cast<std::uint32_t>(index));
    }
    points.push_back(std::move(point));
  }
  return points;
}

}  // namespace

slam::Map ReadColmapTextModel(const std::string& dir, const ColmapImportOptions& options) {
  LCV_CHECK(options.min_sigma_px > 0 && options.prior_sigma_scale > 0);
  const std::string base = dir.empty() || dir.back() == '/' ? dir : dir + "/";
  const std::string cameras_path = base + "cameras.txt";
  const std::string images_path = base + "images.txt";
  const std::string points_path = base + "points3D.txt";

  slam::Map map;
  std::map<std::uint64_t, int> camera_lines;
  for (const TextLine& line : ReadLines(cameras_path)) {
    if (IsBlank(line.text)) continue;
    const LineParser p(cameras_path, line.number);
    const std::vector<std::string> t = Split(line.text);
    const std::uint64_t id = p.PositiveId(t.empty() ? "" : t[0], "CAMERA_ID");
    const slam::CameraParams params = ParseCamera(p, t);
    if (!map.cameras.emplace(id, params).second) {
      p.Fail("duplicate CAMERA_ID " + t[0] + " (first on line " + std::to_string(camera_lines[id]) +
             ")");
    }
    camera_lines[id] = line.number;
  }
  if (map.cameras.empty()) throw InputError(cameras_path, "no cameras");

  std::vector<ColmapImage> images = ParseImages(images_path);
  std::vector<ColmapPoint> points = ParsePoints(points_path);

  const Id max_camera_id = map.cameras.rbegin()->first;
  Id max_image_id = 0;
  for (const ColmapImage& image : images) max_image_id = std::max<Id>(max_image_id, image.id);
  const Id image_offset = max_camera_id;
  const Id point_offset = max_camera_id + max_image_id;

  // Timestamps from the order of the names.
  std::vector<std::size_t> by_name(images.size());
  for (std::size_t i = 0; i < images.size(); ++i) by_name[i] = i;
  std::stable_sort(by_name.begin(), by_name.end(),
                   [&](std::size_t a, std::size_t b) { return images[a].name < images[b].name; });
  std::vector<double> timestamp(images.size());
  for (std::size_t rank = 0; rank < by_name.size(); ++rank) timestamp[by_name[rank]] = rank;

  std::map<std::uint64_t, const ColmapImage*> image_by_id;
  for (std::size_t i = 0; i < images.size(); ++i) {
    ColmapImage& image = images[i];
    const LineParser p(images_path, image.line);
    if (!map.cameras.count(image.camera_id)) {
      p.Fail("CAMERA_ID " + std::to_string(image.camera_id) + " is not in cameras.txt");
    }
    if (!image_by_id.emplace(image.id, &image).second) {
      p.Fail("duplicate IMAGE_ID " + std::to_string(image.id));
    }
    slam::Keyframe kf;
    kf.id = image.id + image_offset;
    kf.camera_id = image.camera_id;
    kf.timestamp = timestamp[i];
    kf.cam_from_world = image.cam_from_world;
    kf.keypoints = image.keypoints;
    map.keyframes.emplace(kf.id, std::move(kf));
  }

  // Cameras once, for the Jacobians of the covariances.
  std::map<std::uint64_t, std::unique_ptr<slam::Camera>> camera_models;
  for (const auto& [id, params] : map.cameras) camera_models[id] = slam::MakeCamera(params);

  // Scale of the prior: median camera-to-point distance over all observations.
  std::vector<double> distances;
  for (const ColmapPoint& point : points) {
    for (const auto& [image_id, index] : point.track) {
      const auto image = image_by_id.find(image_id);
      if (image != image_by_id.end()) {
        distances.push_back((image->second->cam_from_world * point.position).norm());
      }
    }
  }
  double prior_sigma = 1.0;
  if (!distances.empty()) {
    std::nth_element(distances.begin(), distances.begin() + distances.size() / 2, distances.end());
    prior_sigma = options.prior_sigma_scale * std::max(distances[distances.size() / 2], 1e-9);
  }
  const Eigen::Matrix3d prior_info = Eigen::Matrix3d::Identity() / (prior_sigma * prior_sigma);

  std::map<std::uint64_t, int> point_lines;
  for (const ColmapPoint& point : points) {
    const LineParser p(points_path, point.line);
    if (!point_lines.emplace(point.id, point.line).second) {
      p.Fail("duplicate POINT3D_ID " + std::to_string(point.id) + " (first on line " +
             std::to_string(point_lines[point.id]) + ")");
    }
    slam::PointLandmark landmark;
    landmark.id = point.id + point_offset;
    landmark.position = point.position;
    const double sigma_px = std::max(point.error_px, options.min_sigma_px);
    Eigen::Matrix3d info = prior_info;
    for (const auto& [image_id, index] : point.track) {
      const auto it = image_by_id.find(image_id);
      if (it == image_by_id.end()) {
        p.Fail("track element (IMAGE_ID " + std::to_string(image_id) + ", POINT2D_IDX " +
               std::to_string(index) + "): no such image in images.txt");
      }
      const ColmapImage& image = *it->second;
      if (index >= image.point3d_ids.size()) {
        p.Fail("track element (IMAGE_ID " + std::to_string(image_id) + ", POINT2D_IDX " +
               std::to_string(index) + "): image has " + std::to_string(image.point3d_ids.size()) +
               " 2D points");
      }
      if (image.point3d_ids[index] != static_cast<std::int64_t>(point.id)) {
        p.Fail("track element (IMAGE_ID " + std::to_string(image_id) + ", POINT2D_IDX " +
               std::to_string(index) + ") disagrees with images.txt line " +
               std::to_string(image.points_line) + ", which gives POINT3D_ID " +
               std::to_string(image.point3d_ids[index]));
      }
      landmark.observations.push_back({image_id + image_offset, index});
      Eigen::Matrix<double, 2, 3> J_px_p;
      const Eigen::Vector3d p_in_cam = image.cam_from_world * point.position;
      if (camera_models.at(image.camera_id)->Project(p_in_cam, &J_px_p)) {
        const Eigen::Matrix<double, 2, 3> J_px_world =
            J_px_p * image.cam_from_world.RotationMatrix();
        info.noalias() += J_px_world.transpose() * J_px_world / (sigma_px * sigma_px);
      }
    }
    const Eigen::Matrix3d covariance = info.ldlt().solve(Eigen::Matrix3d::Identity());
    landmark.covariance = 0.5 * (covariance + covariance.transpose());
    map.points.emplace(landmark.id, std::move(landmark));
  }

  // Every 2D point that names a 3D point must be in that point's track (COLMAP keeps both).
  for (const ColmapImage& image : images) {
    for (std::size_t k = 0; k < image.point3d_ids.size(); ++k) {
      const std::int64_t point_id = image.point3d_ids[k];
      if (point_id == -1) continue;
      if (!point_lines.count(static_cast<std::uint64_t>(point_id))) {
        throw InputError(images_path + ":" + std::to_string(image.points_line),
                         "2D point " + std::to_string(k) + " names POINT3D_ID " +
                             std::to_string(point_id) + ", which is not in points3D.txt");
      }
    }
  }

  std::ostringstream description;
  description << "imported from COLMAP text model " << dir << " (" << map.cameras.size()
              << " cameras, " << images.size() << " images, " << points.size()
              << " points); ids: camera = CAMERA_ID, keyframe = IMAGE_ID + " << image_offset
              << ", point = POINT3D_ID + " << point_offset;
  map.description = description.str();
  ValidateMap(map, dir);
  return map;
}

}  // namespace lcv::mapping
