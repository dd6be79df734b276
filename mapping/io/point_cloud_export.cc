#include "mapping/io/point_cloud_export.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <sstream>
#include <vector>

#include "mapping/io/atomic_file.h"
#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

struct Rgb {
  std::uint8_t r, g, b;
};
constexpr Rgb kPointColor{255, 255, 255};
constexpr Rgb kLineColor{255, 140, 0};
constexpr Rgb kCameraColor{230, 30, 30};

struct Vertex {
  Eigen::Vector3f p;
  Rgb color;
};

struct Geometry {
  std::vector<Vertex> vertices;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> edges;
  double line_length = 0.0;
};

double AutoLineLength(const slam::Map& map) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  auto extend = [&](const Eigen::Vector3d& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  };
  for (const auto& [id, p] : map.points) extend(p.position);
  for (const auto& [id, l] : map.lines) extend(l.line.anchor);
  for (const auto& [id, kf] : map.keyframes) extend(kf.cam_from_world.Center());
  for (const auto& [id, kf] : map.server_keyframes) extend(kf.cam_from_world.Center());
  const double diagonal = (hi - lo).norm();
  return std::isfinite(diagonal) && diagonal > 0.0 ? 0.02 * diagonal : 1.0;
}

// samples_per_line == 2 gives the two end points (PLY); more gives a polyline (PCD).
Geometry Collect(const slam::Map& map, const PointCloudExportOptions& options, int samples_per_line,
                 bool with_edges) {
  Geometry g;
  g.line_length = options.line_length > 0.0 ? options.line_length : AutoLineLength(map);
  g.vertices.reserve(
      map.points.size() + map.lines.size() * samples_per_line +
      (options.include_cameras ? map.keyframes.size() + map.server_keyframes.size() : 0));
  for (const auto& [id, p] : map.points)
    g.vertices.push_back({p.position.cast<float>(), kPointColor});
  for (const auto& [id, l] : map.lines) {
    const auto first = static_cast<std::uint32_t>(g.vertices.size());
    for (int s = 0; s < samples_per_line; ++s) {
      const double t = (static_cast<double>(s) / (samples_per_line - 1) - 0.5) * g.line_length;
      g.vertices.push_back({l.line.PointAt(t).cast<float>(), kLineColor});
    }
    if (with_edges) g.edges.emplace_back(first, first + 1);
  }
  if (options.include_cameras) {
    for (const auto& [id, kf] : map.keyframes) {
      g.vertices.push_back({kf.cam_from_world.Center().cast<float>(), kCameraColor});
    }
    for (const auto& [id, kf] : map.server_keyframes) {
      g.vertices.push_back({kf.cam_from_world.Center().cast<float>(), kCameraColor});
    }
  }
  return g;
}

template <typename T>
void AppendLittleEndian(std::string* out, T value) {
  static_assert(sizeof(T) <= 8);
  unsigned char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  if constexpr (__BYTE_ORDER__ == __ORDER_BIG_ENDIAN__) std::reverse(bytes, bytes + sizeof(T));
  out->append(reinterpret_cast<const char*>(bytes), sizeof(T));
}

void Summarize(const Geometry& g, PointCloudExportSummary* summary) {
  if (!summary) return;
  summary->vertices = g.vertices.size();
  summary->edges = g.edges.size();
  summary->line_length = g.line_length;
}

}  // namespace

std::optional<PointCloudFormat> PointCloudFormatForPath(const std::string& path) {
  const std::size_t dot = path.rfind('.');
  if (dot == std::string::npos) return std::nullopt;
  std::string ext = path.substr(dot + 1);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == "ply") return PointCloudFormat::kPly;
  if (ext == "pcd") return PointCloudFormat::kPcd;
  return std::nullopt;
}

std::string SerializePly(const slam::Map& map, const PointCloudExportOptions& options,
                         PointCloudExportSummary* summary) {
  const Geometry g = Collect(map, options, 2, /*with_edges=*/true);
  Summarize(g, summary);
  std::ostringstream header;
  header << "ply\nformat " << (options.ascii ? "ascii" : "binary_little_endian") << " 1.0\n"
         << "comment lcv map export: points white, lines orange (segments of length "
         << g.line_length << " centred on their anchors), cameras red\n"
         << "element vertex " << g.vertices.size() << "\n"
         << "property float x\nproperty float y\nproperty float z\n"
         << "property uchar red\nproperty uchar green\nproperty uchar blue\n"
         << "element edge " << g.edges.size() << "\n"
         << "property int vertex1\nproperty int vertex2\n"
         << "end_header\n";
  std::string out = header.str();
  if (options.ascii) {
    std::ostringstream body;
    body.precision(9);  // float32 round trip
    for (const Vertex& v : g.vertices) {
      body << v.p.x() << ' ' << v.p.y() << ' ' << v.p.z() << ' ' << int(v.color.r) << ' '
           << int(v.color.g) << ' ' << int(v.color.b) << '\n';
    }
    for (const auto& [a, b] : g.edges) body << a << ' ' << b << '\n';
    return out + body.str();
  }
  out.reserve(out.size() + g.vertices.size() * 15 + g.edges.size() * 8);
  for (const Vertex& v : g.vertices) {
    for (int i = 0; i < 3; ++i) AppendLittleEndian(&out, v.p(i));
    out.push_back(static_cast<char>(v.color.r));
    out.push_back(static_cast<char>(v.color.g));
    out.push_back(static_cast<char>(v.color.b));
  }
  for (const auto& [a, b] : g.edges) {
    AppendLittleEndian(&out, static_cast<std::int32_t>(a));
    AppendLittleEndian(&out, static_cast<std::int32_t>(b));
  }
  return out;
}

std::string SerializePcd(const slam::Map& map, const PointCloudExportOptions& options,
                         PointCloudExportSummary* summary) {
  LCV_CHECK(options.samples_per_line >= 2) << options.samples_per_line;
  const Geometry g = Collect(map, options, options.samples_per_line, /*with_edges=*/false);
  Summarize(g, summary);
  std::ostringstream header;
  header << "# .PCD v0.7 - lcv map export: points white, lines orange (polylines of "
         << options.samples_per_line << " samples over " << g.line_length
         << " centred on their anchors), cameras red\n"
         << "VERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\n"
         << "WIDTH " << g.vertices.size() << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\n"
         << "POINTS " << g.vertices.size() << "\nDATA " << (options.ascii ? "ascii" : "binary")
         << "\n";
  std::string out = header.str();
  // PCL packs colour as 0x00RRGGBB reinterpreted as a float.
  auto packed = [](const Rgb& c) {
    const std::uint32_t bits = std::uint32_t(c.r) << 16 | std::uint32_t(c.g) << 8 | c.b;
    float f;
    std::memcpy(&f, &bits, 4);
    return f;
  };
  if (options.ascii) {
    std::ostringstream body;
    body.precision(9);
    for (const Vertex& v : g.vertices) {
      body << v.p.x() << ' ' << v.p.y() << ' ' << v.p.z() << ' ' << packed(v.color) << '\n';
    }
    return out + body.str();
  }
  out.reserve(out.size() + g.vertices.size() * 16);
  for (const Vertex& v : g.vertices) {
    for (int i = 0; i < 3; ++i) AppendLittleEndian(&out, v.p(i));
    AppendLittleEndian(&out, packed(v.color));
  }
  return out;
}

PointCloudExportSummary ExportPointCloud(const slam::Map& map, const std::string& path,
                                         const PointCloudExportOptions& options) {
  const auto format = PointCloudFormatForPath(path);
  if (!format) throw InputError(path, "unknown point cloud format (expected .ply or .pcd)");
  PointCloudExportSummary summary;
  const std::string bytes = *format == PointCloudFormat::kPly
                                ? SerializePly(map, options, &summary)
                                : SerializePcd(map, options, &summary);
  WriteFileAtomically(path, bytes);
  return summary;
}

}  // namespace lcv::mapping
