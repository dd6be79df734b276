#include "render/map_snapshot.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "mapping/io/atomic_file.h"
#include "mapping/io/media.h"
#include "render/gl_functions.h"
#include "render/offscreen_context.h"
#include "slam/util/error.h"

namespace lcv::render {
namespace {

using internal::Gl;
constexpr double kPi = 3.14159265358979323846;

// Colours of the paper's figures, RGBA.
using Rgba = std::array<unsigned char, 4>;
constexpr Rgba kLineColor = {30, 90, 220, 255};
constexpr Rgba kPointColor = {0, 0, 0, 255};
constexpr Rgba kRestoredColor = {255, 140, 0, 255};
constexpr Rgba kClientColor = {0, 170, 0, 255};
constexpr Rgba kClientTrajectoryColor = {0, 110, 0, 255};
constexpr Rgba kServerColor = {220, 0, 0, 255};
constexpr Rgba kServerTrajectoryColor = {140, 0, 0, 255};
constexpr Rgba kLoopColor = {230, 0, 230, 255};
constexpr Rgba kNoRiskColor = {170, 170, 170, 255};

Rgba RiskColor(double risk) {
  // blue (0) -> yellow (0.5) -> red (1).
  risk = std::clamp(risk, 0.0, 1.0);
  const Eigen::Vector3d blue(30, 90, 220), yellow(240, 200, 30), red(220, 20, 20);
  const Eigen::Vector3d c = risk < 0.5 ? blue + (yellow - blue) * (2 * risk)
                                       : yellow + (red - yellow) * (2 * risk - 1);
  return {static_cast<unsigned char>(std::lround(c.x())), static_cast<unsigned char>(std::lround(c.y())),
          static_cast<unsigned char>(std::lround(c.z())), 255};
}

cv::Scalar Bgr(const Rgba& c) { return cv::Scalar(c[2], c[1], c[0]); }

double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0.0;
  const size_t k = std::min(values.size() - 1, static_cast<size_t>(q * (values.size() - 1) + 0.5));
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[k];
}

// A batch of coloured vertices for one glDrawArrays call.
struct Batch {
  std::vector<float> xyz;
  std::vector<unsigned char> rgba;
  void Add(const Eigen::Vector3d& p_in_cam, const Rgba& c, unsigned char alpha = 255) {
    xyz.insert(xyz.end(), {static_cast<float>(p_in_cam.x()), static_cast<float>(p_in_cam.y()),
                           static_cast<float>(p_in_cam.z())});
    rgba.insert(rgba.end(), {c[0], c[1], c[2], alpha});
  }
  void Clear() {
    xyz.clear();
    rgba.clear();
  }
  int size() const { return static_cast<int>(xyz.size() / 3); }
};

slam::Rigid3d LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                     const Eigen::Vector3d& up) {
  const Eigen::Vector3d z = (target - eye).normalized();
  Eigen::Vector3d x = z.cross(up);
  if (x.norm() < 1e-9) x = z.unitOrthogonal();
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d world_from_cam;
  world_from_cam << x, y, z;
  Eigen::Quaterniond q(world_from_cam);
  q.normalize();
  return slam::Rigid3d(q, eye).Inverse();
}

// Pinhole intrinsics of a map camera scaled (uniformly, centred) to the snapshot size.
void FitPinhole(const slam::CameraParams& camera, int cols, int rows, SnapshotCamera* out) {
  double fx = camera.fx, fy = camera.fy, cx = camera.cx, cy = camera.cy;
  if (camera.model != slam::CameraModel::kPerspective || fx <= 0) {
    fx = fy = 0.5 * camera.cols;  // 90 degrees across the width
    cx = 0.5 * (camera.cols - 1);
    cy = 0.5 * (camera.rows - 1);
  }
  const double s = std::min(static_cast<double>(cols) / camera.cols,
                            static_cast<double>(rows) / camera.rows);
  out->fx = fx * s;
  out->fy = fy * s;
  out->cx = (cx + 0.5) * s - 0.5 + 0.5 * (cols - camera.cols * s);
  out->cy = (cy + 0.5) * s - 0.5 + 0.5 * (rows - camera.rows * s);
}

std::array<double, 16> Projection(const SnapshotCamera& k) {
  std::array<double, 16> m{};
  if (k.orthographic) {
    m[0] = 2.0 * k.fx / k.cols;
    m[12] = 2.0 * (k.cx + 0.5) / k.cols - 1.0;
    m[5] = -2.0 * k.fy / k.rows;
    m[13] = 1.0 - 2.0 * (k.cy + 0.5) / k.rows;
    m[10] = 2.0 / (k.far - k.near);
    m[14] = -(k.far + k.near) / (k.far - k.near);
    m[15] = 1.0;
  } else {
    m[0] = 2.0 * k.fx / k.cols;
    m[8] = 2.0 * (k.cx + 0.5) / k.cols - 1.0;
    m[5] = -2.0 * k.fy / k.rows;
    m[9] = 1.0 - 2.0 * (k.cy + 0.5) / k.rows;
    m[10] = (k.far + k.near) / (k.far - k.near);
    m[14] = -2.0 * k.far * k.near / (k.far - k.near);
    m[11] = 1.0;
  }
  return m;
}

void DrawLegend(const slam::Map& map, const SnapshotOptions& options, cv::Mat* image) {
  struct Entry {
    Rgba color;
    std::string label;
    bool line;
  };
  std::vector<Entry> entries;
  const auto count = [](size_t n, const char* what) { return std::to_string(n) + " " + what; };
  if (!map.lines.empty() && options.color_by == SnapshotColorBy::kSource) {
    entries.push_back({kLineColor, count(map.lines.size(), "lines (line cloud)"), true});
  }
  if (!map.points.empty()) entries.push_back({kPointColor, count(map.points.size(), "points X"), false});
  size_t restored = 0;
  for (const auto& [id, line] : map.lines) restored += line.restored_point.has_value();
  if (restored) entries.push_back({kRestoredColor, count(restored, "restored points X'"), false});
  if (!map.keyframes.empty()) {
    entries.push_back({kClientColor, count(map.keyframes.size(), "client keyframes"), true});
  }
  if (!map.server_keyframes.empty()) {
    entries.push_back({kServerColor, count(map.server_keyframes.size(), "server keyframes"), true});
  }
  if (!options.loop_edges.empty()) {
    entries.push_back({kLoopColor, count(options.loop_edges.size(), "loop edges"), true});
  }
  const double scale = std::max(0.35, image->cols / 1280.0 * 0.55);
  const int row_h = static_cast<int>(std::lround(26 * scale / 0.55));
  const int pad = row_h / 2;
  const bool risk = options.color_by == SnapshotColorBy::kRisk;
  const int height = pad * 2 + row_h * static_cast<int>(entries.size()) + (risk ? 2 * row_h : 0);
  const int width = static_cast<int>(std::lround(330 * scale / 0.55));
  const cv::Rect box(pad, pad, width, height);
  cv::Mat roi = (*image)(box & cv::Rect(0, 0, image->cols, image->rows));
  roi = roi * 0.15 + cv::Scalar::all(255 * 0.85);  // light panel over the drawing
  cv::rectangle(*image, box, cv::Scalar::all(90), 1, cv::LINE_8);
  int y = box.y + pad + row_h / 2;
  for (const auto& e : entries) {
    const cv::Point a(box.x + pad, y), b(box.x + pad + row_h, y);
    if (e.line) {
      cv::line(*image, a, b, Bgr(e.color), std::max(2, row_h / 8), cv::LINE_8);
    } else {
      cv::circle(*image, (a + b) / 2, std::max(2, row_h / 6), Bgr(e.color), -1, cv::LINE_8);
    }
    cv::putText(*image, e.label, cv::Point(b.x + pad, y + row_h / 4), cv::FONT_HERSHEY_SIMPLEX,
                scale, cv::Scalar::all(20), 1, cv::LINE_8);
    y += row_h;
  }
  if (risk) {
    cv::putText(*image, "line risk 0 .. 1", cv::Point(box.x + pad, y + row_h / 4),
                cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar::all(20), 1, cv::LINE_8);
    y += row_h / 2;
    const int bar_w = width - 2 * pad;
    for (int i = 0; i < bar_w; ++i) {
      cv::line(*image, cv::Point(box.x + pad + i, y), cv::Point(box.x + pad + i, y + row_h / 2),
               Bgr(RiskColor(static_cast<double>(i) / (bar_w - 1))), 1, cv::LINE_8);
    }
  }
}


// The line cloud is splatted on the CPU into a per-pixel count (and colour sum), then shown as
// one texture: 100,000 box-clipped lines are ~70 M fragments, which llvmpipe blends in > 1 s,
// while counting them here takes ~0.1 s; and coverage 1 - (1 - alpha)^n is independent of the
// drawing order, so the picture does not depend on line ids.
class LineLayer {
 public:
  LineLayer(int cols, int rows, bool colored)
      : cols_(cols), rows_(rows), count_(static_cast<size_t>(cols) * rows, 0) {
    if (colored) color_sum_.assign(3 * count_.size(), 0);
  }

  // Pixel-space segment (pixel centres at integers); clipped to the image here.
  void Draw(Eigen::Vector2d a, Eigen::Vector2d b, const Rgba& color) {
    // Huge (finite) map coordinates give infinite or NaN pixels; a NaN passes every comparison
    // of the clipping below, and converting it to int indexed far outside count_ (issue 16).
    if (!a.allFinite() || !b.allFinite()) return;
    // Liang-Barsky against [-0.5, cols - 0.5] x [-0.5, rows - 0.5].
    double t0 = 0, t1 = 1;
    const Eigen::Vector2d d = b - a;
    const double lo[2] = {-0.5, -0.5}, hi[2] = {cols_ - 0.5, rows_ - 0.5};
    for (int k = 0; k < 2; ++k) {
      if (std::abs(d[k]) < 1e-12) {
        if (a[k] < lo[k] || a[k] > hi[k]) return;
        continue;
      }
      double s0 = (lo[k] - a[k]) / d[k], s1 = (hi[k] - a[k]) / d[k];
      if (s0 > s1) std::swap(s0, s1);
      t0 = std::max(t0, s0);
      t1 = std::min(t1, s1);
    }
    if (t0 > t1) return;
    const Eigen::Vector2d p = a + t0 * d, q = a + t1 * d;
    if (!p.allFinite() || !q.allFinite()) return;  // b - a overflowed
    const bool x_major = std::abs(q.x() - p.x()) >= std::abs(q.y() - p.y());
    const int major = x_major ? 0 : 1, minor = 1 - major;
    double from = p[major], to = q[major], at = p[minor];
    double slope = (q[minor] - p[minor]) / (std::abs(to - from) < 1e-12 ? 1.0 : (to - from));
    if (from > to) {
      std::swap(from, to);
      at = q[minor];
    }
    // Clipping keeps [from, to] inside the image up to rounding; the clamps make every index
    // below valid whatever the rounding did.
    const int major_size = x_major ? cols_ : rows_, minor_size = x_major ? rows_ : cols_;
    const int first = static_cast<int>(std::max(0.0, std::ceil(from)));
    const int last = static_cast<int>(std::min<double>(major_size - 1, std::floor(to)));
    for (int i = first; i <= last; ++i) {
      const double minor_at = at + (i - from) * slope;
      if (!(minor_at >= -0.5 && minor_at < minor_size - 0.5)) continue;  // also NaN
      const int j = static_cast<int>(std::lround(minor_at));
      if (j < 0 || j >= minor_size) continue;
      const size_t index = x_major ? static_cast<size_t>(j) * cols_ + i : static_cast<size_t>(i) * cols_ + j;
      if (count_[index] == 0xFFFF) continue;
      ++count_[index];
      if (!color_sum_.empty()) {
        for (int c = 0; c < 3; ++c) color_sum_[3 * index + c] += color[c];
      }
    }
  }

  // RGBA image, top row first: white where empty, else the mean colour with coverage
  // 1 - (1 - alpha)^n over white.
  std::vector<unsigned char> Compose(const Rgba& color, double alpha) const {
    std::vector<unsigned char> rgba(4 * count_.size(), 255);
    std::vector<double> coverage(256);
    for (int n = 0; n < 256; ++n) coverage[n] = 1.0 - std::pow(1.0 - alpha, n);
    for (size_t i = 0; i < count_.size(); ++i) {
      const int n = count_[i];
      if (n == 0) continue;
      const double c = coverage[std::min(n, 255)];
      for (int k = 0; k < 3; ++k) {
        const double mean = color_sum_.empty() ? color[k] : double(color_sum_[3 * i + k]) / n;
        rgba[4 * i + k] = static_cast<unsigned char>(std::lround(255.0 * (1.0 - c) + mean * c));
      }
    }
    return rgba;
  }

 private:
  int cols_, rows_;
  std::vector<std::uint16_t> count_;
  std::vector<std::uint32_t> color_sum_;
};
}  // namespace

std::optional<Eigen::Vector2d> SnapshotCamera::Project(const Eigen::Vector3d& p_in_world) const {
  const Eigen::Vector3d p = cam_from_world * p_in_world;
  if (orthographic) return Eigen::Vector2d(fx * p.x() + cx, fy * p.y() + cy);
  if (p.z() <= 0) return std::nullopt;
  return Eigen::Vector2d(fx * p.x() / p.z() + cx, fy * p.y() / p.z() + cy);
}

MapFrame ComputeMapFrame(const slam::Map& map) {
  std::vector<Eigen::Vector3d> content;
  for (const auto& [id, p] : map.points) content.push_back(p.position);
  for (const auto& [id, l] : map.lines) {
    if (l.restored_point) content.push_back(*l.restored_point);
  }
  Eigen::Vector3d up_sum = Eigen::Vector3d::Zero();
  for (const auto& [id, kf] : map.keyframes) {
    content.push_back(kf.cam_from_world.Center());
    up_sum += kf.cam_from_world.rotation.conjugate() * Eigen::Vector3d(0, -1, 0);
  }
  for (const auto& [id, kf] : map.server_keyframes) {
    content.push_back(kf.cam_from_world.Center());
    up_sum += kf.cam_from_world.rotation.conjugate() * Eigen::Vector3d(0, -1, 0);
  }
  if (map.points.empty()) {
    for (const auto& [id, l] : map.lines) content.push_back(l.line.anchor);
  }
  MapFrame frame;
  if (content.empty()) return frame;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : content) mean += p;
  mean /= static_cast<double>(content.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const auto& p : content) scatter += (p - mean) * (p - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> pca(scatter);  // ascending eigenvalues
  Eigen::Vector3d up = up_sum.norm() > 0.3 * (map.keyframes.size() + map.server_keyframes.size())
                           ? Eigen::Vector3d(up_sum.normalized())
                           : Eigen::Vector3d(pca.eigenvectors().col(0));
  // Horizontal principal axis: the largest-spread direction orthogonal to up.
  Eigen::Vector3d axis1 = Eigen::Vector3d::Zero();
  for (int k = 2; k >= 0 && axis1.norm() < 1e-6; --k) {
    const Eigen::Vector3d e = pca.eigenvectors().col(k);
    axis1 = e - e.dot(up) * up;
  }
  if (axis1.norm() < 1e-6) axis1 = up.unitOrthogonal();
  axis1.normalize();
  const Eigen::Vector3d axis2 = up.cross(axis1);
  frame.origin = mean;
  frame.world_from_frame << axis1, axis2, up;
  std::array<std::vector<double>, 3> coords;
  for (const auto& p : content) {
    const Eigen::Vector3d q = frame.ToFrame(p);
    for (int d = 0; d < 3; ++d) coords[d].push_back(q[d]);
  }
  for (int d = 0; d < 3; ++d) {
    frame.box_min[d] = Percentile(coords[d], 0.005);
    frame.box_max[d] = Percentile(coords[d], 0.995);
  }
  const double pad = 0.05 * std::max(1e-3, (frame.box_max - frame.box_min).maxCoeff());
  frame.box_min -= Eigen::Vector3d::Constant(pad);
  frame.box_max += Eigen::Vector3d::Constant(pad);
  return frame;
}

std::optional<std::pair<Eigen::Vector3d, Eigen::Vector3d>> ClipLineToBox(const slam::Line3d& line,
                                                                        const MapFrame& frame) {
  // Slab method in the box frame: the line is a + s d, s in (-inf, inf).
  const Eigen::Vector3d a = frame.ToFrame(line.anchor);
  const Eigen::Vector3d d = frame.world_from_frame.transpose() * line.direction;
  double s_min = -std::numeric_limits<double>::infinity();
  double s_max = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k) {
    if (std::abs(d[k]) < 1e-12) {
      if (a[k] < frame.box_min[k] || a[k] > frame.box_max[k]) return std::nullopt;
      continue;
    }
    double s0 = (frame.box_min[k] - a[k]) / d[k], s1 = (frame.box_max[k] - a[k]) / d[k];
    if (s0 > s1) std::swap(s0, s1);
    s_min = std::max(s_min, s0);
    s_max = std::min(s_max, s1);
  }
  if (!(s_min < s_max)) return std::nullopt;
  return std::make_pair(line.PointAt(s_min), line.PointAt(s_max));
}

struct MapSnapshotRenderer::Impl {
  OffscreenContext context;
  Batch batch;
  unsigned int layer_texture = 0;  // GL name of the line layer, created on first use

  void Flush(GLenum mode, float width) {
    if (batch.size() == 0) return;
    const auto& gl = Gl();
    if (mode == GL_POINTS) {
      gl.PointSize(width);
    } else {
      gl.LineWidth(width);
    }
    gl.VertexPointer(3, GL_FLOAT, 0, batch.xyz.data());
    gl.ColorPointer(4, GL_UNSIGNED_BYTE, 0, batch.rgba.data());
    gl.DrawArrays(mode, 0, batch.size());
    batch.Clear();
  }
};

MapSnapshotRenderer::MapSnapshotRenderer() : impl_(std::make_unique<Impl>()) {}
MapSnapshotRenderer::~MapSnapshotRenderer() = default;

Snapshot MapSnapshotRenderer::Render(const slam::Map& map, const SnapshotOptions& options) {
  LCV_CHECK(options.cols >= 16 && options.rows >= 16 && options.cols <= 8192 && options.rows <= 8192)
      << options.cols << "x" << options.rows;
  const MapFrame frame = ComputeMapFrame(map);
  const Eigen::Vector3d up = frame.world_from_frame.col(2);
  const Eigen::Vector3d extent = frame.box_max - frame.box_min;
  const Eigen::Vector3d centre = frame.ToWorld(0.5 * (frame.box_min + frame.box_max));
  const double radius = 0.5 * frame.Diagonal();

  SnapshotCamera view;
  view.cols = options.cols;
  view.rows = options.rows;
  switch (options.view) {
    case SnapshotView::kTop: {
      view.orthographic = true;
      view.fx = view.fy = 0.94 * std::min(options.cols / std::max(extent.x(), 1e-9),
                                          options.rows / std::max(extent.y(), 1e-9));
      view.cx = 0.5 * (options.cols - 1);
      view.cy = 0.5 * (options.rows - 1);
      // Looking down: camera z = -up, x = axis1, y = -axis2.
      Eigen::Matrix3d world_from_cam;
      world_from_cam << frame.world_from_frame.col(0), -frame.world_from_frame.col(1), -up;
      const Eigen::Vector3d eye = centre + (0.5 * extent.z() + radius) * up;
      view.cam_from_world = slam::Rigid3d(Eigen::Quaterniond(world_from_cam), eye).Inverse();
      view.near = -1.0;
      view.far = 4.0 * radius + extent.z() + 1.0;
      break;
    }
    case SnapshotView::kOblique: {
      const double hfov = 60.0 * kPi / 180.0;
      view.fx = view.fy = 0.5 * options.cols / std::tan(0.5 * hfov);
      view.cx = 0.5 * (options.cols - 1);
      view.cy = 0.5 * (options.rows - 1);
      const double half_fov = std::atan(0.5 * std::min(options.cols, options.rows) / view.fx);
      const double distance = std::max(radius, 1e-6) / std::sin(half_fov) * 0.85;
      const double az = options.azimuth_deg * kPi / 180.0, el = options.elevation_deg * kPi / 180.0;
      const Eigen::Vector3d dir = std::cos(el) * (std::cos(az) * frame.world_from_frame.col(0) +
                                                  std::sin(az) * frame.world_from_frame.col(1)) +
                                  std::sin(el) * up;
      view.cam_from_world = LookAt(centre + distance * dir, centre, up);
      view.near = 0.01 * distance;
      view.far = distance + 4.0 * radius;
      break;
    }
    case SnapshotView::kKeyframe: {
      const slam::CameraParams* camera = nullptr;
      if (const auto kf = map.keyframes.find(options.keyframe_id); kf != map.keyframes.end()) {
        view.cam_from_world = kf->second.cam_from_world;
        camera = &map.cameras.at(kf->second.camera_id);
      } else if (const auto skf = map.server_keyframes.find(options.keyframe_id);
                 skf != map.server_keyframes.end()) {
        view.cam_from_world = skf->second.cam_from_world;
        camera = &map.cameras.at(skf->second.camera_id);
      }
      LCV_CHECK(camera) << "no keyframe " << options.keyframe_id;
      FitPinhole(*camera, options.cols, options.rows, &view);
      view.near = 1e-3 * std::max(radius, 1e-3);
      view.far = 10.0 * std::max(radius, 1e-3) + (view.cam_from_world.Center() - centre).norm();
      break;
    }
    case SnapshotView::kExplicit: {
      LCV_CHECK(options.camera && !options.camera->Problem()) << "explicit view without a camera";
      view.cam_from_world = options.cam_from_world;
      FitPinhole(*options.camera, options.cols, options.rows, &view);
      view.near = 1e-3 * std::max(radius, 1e-3);
      view.far = 10.0 * std::max(radius, 1e-3) + (view.cam_from_world.Center() - centre).norm();
      break;
    }
  }

  auto& ctx = impl_->context;
  ctx.Bind(options.cols, options.rows);
  const auto& gl = Gl();
  gl.ClearColor(1.f, 1.f, 1.f, 1.f);
  gl.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  gl.Disable(GL_DEPTH_TEST);
  gl.Disable(GL_TEXTURE_2D);
  gl.Disable(GL_LIGHTING);
  gl.Disable(GL_CULL_FACE);
  gl.Disable(GL_LINE_SMOOTH);
  gl.Disable(GL_POINT_SMOOTH);
  gl.Enable(GL_BLEND);
  gl.BlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
  gl.ShadeModel(GL_FLAT);
  gl.MatrixMode(GL_PROJECTION);
  const auto projection = Projection(view);
  gl.LoadMatrixd(projection.data());
  gl.MatrixMode(GL_MODELVIEW);
  gl.LoadIdentity();  // vertices go to the camera frame here, in double
  gl.EnableClientState(GL_VERTEX_ARRAY);
  gl.EnableClientState(GL_COLOR_ARRAY);

  const Eigen::Matrix3d r = view.cam_from_world.RotationMatrix();
  const Eigen::Vector3d t = view.cam_from_world.translation;
  const auto cam = [&](const Eigen::Vector3d& p) -> Eigen::Vector3d { return r * p + t; };
  Batch& batch = impl_->batch;
  const float px_scale = static_cast<float>(std::max(1.0, options.cols / 1280.0));

  // 1. Line cloud (CPU splatting, see LineLayer), shown as a screen-sized texture.
  const double n_lines = static_cast<double>(map.lines.size());
  const double alpha = std::clamp(std::sqrt(400.0 / std::max(1.0, n_lines)), 0.04, 0.9);
  if (!map.lines.empty()) {
    const bool by_risk = options.color_by == SnapshotColorBy::kRisk;
    LineLayer layer(options.cols, options.rows, by_risk);
    const auto to_pixel = [&](const Eigen::Vector3d& p) -> Eigen::Vector2d {
      return view.orthographic ? Eigen::Vector2d(view.fx * p.x() + view.cx, view.fy * p.y() + view.cy)
                               : Eigen::Vector2d(view.fx * p.x() / p.z() + view.cx,
                                                 view.fy * p.y() / p.z() + view.cy);
    };
    for (const auto& [id, l] : map.lines) {
      const auto segment = ClipLineToBox(l.line, frame);
      if (!segment) continue;
      Eigen::Vector3d a = cam(segment->first), b = cam(segment->second);
      if (!view.orthographic) {  // keep the part in front of the near plane
        if (a.z() < view.near && b.z() < view.near) continue;
        if (a.z() < view.near) a = a + (view.near - a.z()) / (b.z() - a.z()) * (b - a);
        if (b.z() < view.near) b = b + (view.near - b.z()) / (a.z() - b.z()) * (a - b);
      }
      Rgba color = kLineColor;
      if (by_risk) {
        const auto risk = options.line_risk.find(id);
        color = risk == options.line_risk.end() ? kNoRiskColor : RiskColor(risk->second);
      }
      layer.Draw(to_pixel(a), to_pixel(b), color);
    }
    const std::vector<unsigned char> rgba = layer.Compose(kLineColor, alpha);
    if (impl_->layer_texture == 0) gl.GenTextures(1, &impl_->layer_texture);
    gl.BindTexture(GL_TEXTURE_2D, impl_->layer_texture);
    gl.TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, options.cols, options.rows, 0, GL_RGBA,
                  GL_UNSIGNED_BYTE, rgba.data());
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    gl.TexEnvi(GL_TEXTURE_ENV, GL_TEXTURE_ENV_MODE, GL_REPLACE);
    gl.Enable(GL_TEXTURE_2D);
    gl.Disable(GL_BLEND);
    gl.MatrixMode(GL_PROJECTION);
    gl.LoadIdentity();
    // Full-viewport quad in clip space; texture row 0 (image top) at the window top.
    static constexpr float kQuad[8] = {-1, -1, 1, -1, 1, 1, -1, 1};
    static constexpr float kQuadTex[8] = {0, 1, 1, 1, 1, 0, 0, 0};
    gl.DisableClientState(GL_COLOR_ARRAY);
    gl.EnableClientState(GL_TEXTURE_COORD_ARRAY);
    gl.VertexPointer(2, GL_FLOAT, 0, kQuad);
    gl.TexCoordPointer(2, GL_FLOAT, 0, kQuadTex);
    gl.Color4ub(255, 255, 255, 255);
    gl.DrawArrays(GL_TRIANGLE_FAN, 0, 4);
    gl.DisableClientState(GL_TEXTURE_COORD_ARRAY);
    gl.EnableClientState(GL_COLOR_ARRAY);
    gl.Disable(GL_TEXTURE_2D);
    gl.Enable(GL_BLEND);
    gl.LoadMatrixd(projection.data());
    gl.MatrixMode(GL_MODELVIEW);
  }

  // 2. Trajectories, ordered by timestamp then id.
  const auto trajectory = [&](auto const& keyframes, const Rgba& color) {
    std::vector<std::pair<double, Eigen::Vector3d>> stamped;
    for (const auto& [id, kf] : keyframes) stamped.push_back({kf.timestamp, kf.cam_from_world.Center()});
    std::stable_sort(stamped.begin(), stamped.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    for (size_t i = 1; i < stamped.size(); ++i) {
      batch.Add(cam(stamped[i - 1].second), color);
      batch.Add(cam(stamped[i].second), color);
    }
    impl_->Flush(GL_LINES, 2.f * px_scale);
  };
  trajectory(map.keyframes, kClientTrajectoryColor);
  trajectory(map.server_keyframes, kServerTrajectoryColor);

  // 3. Keyframe frustums: size from the keyframe spacing, at most 4 % of the box diagonal.
  std::vector<double> spacing;
  {
    std::vector<Eigen::Vector3d> centres;
    for (const auto& [id, kf] : map.keyframes) centres.push_back(kf.cam_from_world.Center());
    for (const auto& [id, kf] : map.server_keyframes) centres.push_back(kf.cam_from_world.Center());
    for (size_t i = 1; i < centres.size(); ++i) spacing.push_back((centres[i] - centres[i - 1]).norm());
  }
  double frustum = 0.04 * frame.Diagonal();
  if (!spacing.empty()) frustum = std::min(frustum, std::max(1.2 * Percentile(spacing, 0.5), 0.01 * frame.Diagonal()));
  const auto draw_frustum = [&](const slam::Rigid3d& cam_from_world, const slam::CameraParams& camera,
                                const Rgba& color) {
    const slam::Rigid3d world_from_cam = cam_from_world.Inverse();
    const double aspect = camera.cols > 0 && camera.rows > 0 ? double(camera.rows) / camera.cols : 0.75;
    const double half_w = 0.6 * frustum, half_h = half_w * aspect;
    const Eigen::Vector3d o = world_from_cam.translation;
    const Eigen::Vector3d c[4] = {world_from_cam * Eigen::Vector3d(-half_w, -half_h, frustum),
                                  world_from_cam * Eigen::Vector3d(half_w, -half_h, frustum),
                                  world_from_cam * Eigen::Vector3d(half_w, half_h, frustum),
                                  world_from_cam * Eigen::Vector3d(-half_w, half_h, frustum)};
    for (int k = 0; k < 4; ++k) {
      batch.Add(cam(o), color);
      batch.Add(cam(c[k]), color);
      batch.Add(cam(c[k]), color);
      batch.Add(cam(c[(k + 1) % 4]), color);
    }
  };
  const slam::CameraParams no_camera;
  const auto camera_of = [&](slam::Id id) -> const slam::CameraParams& {
    const auto it = map.cameras.find(id);
    return it == map.cameras.end() ? no_camera : it->second;
  };
  for (const auto& [id, kf] : map.server_keyframes) {
    if (options.view == SnapshotView::kKeyframe && id == options.keyframe_id) continue;
    draw_frustum(kf.cam_from_world, camera_of(kf.camera_id), kServerColor);
  }
  for (const auto& [id, kf] : map.keyframes) {
    if (options.view == SnapshotView::kKeyframe && id == options.keyframe_id) continue;
    draw_frustum(kf.cam_from_world, camera_of(kf.camera_id), kClientColor);
  }
  impl_->Flush(GL_LINES, 1.5f * px_scale);

  // 4. Loop edges.
  const auto centre_of = [&](slam::Id id) -> std::optional<Eigen::Vector3d> {
    if (const auto kf = map.keyframes.find(id); kf != map.keyframes.end()) return kf->second.cam_from_world.Center();
    if (const auto kf = map.server_keyframes.find(id); kf != map.server_keyframes.end()) return kf->second.cam_from_world.Center();
    return std::nullopt;
  };
  for (const auto& [a, b] : options.loop_edges) {
    const auto ca = centre_of(a), cb = centre_of(b);
    if (!ca || !cb) continue;
    batch.Add(cam(*ca), kLoopColor);
    batch.Add(cam(*cb), kLoopColor);
  }
  impl_->Flush(GL_LINES, 3.f * px_scale);

  // 5. Points X, then restored points X' on top.
  const float point_size = (map.points.size() > 50000 ? 2.f : 3.f) * px_scale;
  for (const auto& [id, p] : map.points) batch.Add(cam(p.position), kPointColor);
  impl_->Flush(GL_POINTS, point_size);
  for (const auto& [id, l] : map.lines) {
    if (l.restored_point) batch.Add(cam(*l.restored_point), kRestoredColor);
  }
  impl_->Flush(GL_POINTS, point_size + 1.f);

  gl.DisableClientState(GL_VERTEX_ARRAY);
  gl.DisableClientState(GL_COLOR_ARRAY);
  gl.Disable(GL_BLEND);

  Snapshot snapshot;
  snapshot.image = ctx.ReadBgr();
  snapshot.camera = view;
  if (options.legend) DrawLegend(map, options, &snapshot.image);
  return snapshot;
}

Snapshot RenderMapSnapshot(const slam::Map& map, const SnapshotOptions& options) {
  MapSnapshotRenderer renderer;
  return renderer.Render(map, options);
}

void WritePng(const cv::Mat& image, const std::string& path) {
  const std::vector<unsigned char> png = mapping::EncodePng(image, 6, path);
  mapping::WriteFileAtomically(path, std::string(png.begin(), png.end()));
}

}  // namespace lcv::render
