#include "mapping/io/point_cloud_export.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <sstream>

#include "mapping/io/atomic_file.h"
#include "mapping/line_cloud.h"
#include "mapping/synthetic_map.h"
#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

slam::Map MixedMap() {
  SyntheticMapOptions o;
  o.num_points = 60;
  o.num_keyframes = 5;
  o.seed = 4;
  slam::Map map = MakeSyntheticPointMap(o);
  // Half of the points become lines; keep the other half as points.
  slam::Map lines = ConvertToLineCloud(map, LineCloudOptions{3});
  int i = 0;
  for (auto it = map.points.begin(); it != map.points.end();) {
    if (i++ % 2) {
      map.lines[it->first] = lines.lines.at(it->first);
      map.lines[it->first].server_keyframe_ids.clear();
      it = map.points.erase(it);
    } else {
      ++it;
    }
  }
  map.server_keyframes[999] = lines.server_keyframes.begin()->second;
  map.server_keyframes[999].id = 999;
  map.server_keyframes[999].line_ids.clear();
  return map;
}

// A parsed header and the bytes after it.
struct Parsed {
  std::map<std::string, std::string> lines;  // first word -> rest of line (last one wins)
  std::vector<std::string> all;
  std::string body;
};

Parsed ParseHeader(const std::string& bytes, const std::string& end_marker_prefix) {
  Parsed out;
  std::size_t pos = 0;
  while (pos < bytes.size()) {
    const std::size_t eol = bytes.find('\n', pos);
    const std::string line = bytes.substr(pos, eol - pos);
    pos = eol + 1;
    out.all.push_back(line);
    const std::size_t space = line.find(' ');
    out.lines[line.substr(0, space)] = space == std::string::npos ? "" : line.substr(space + 1);
    if (line.rfind(end_marker_prefix, 0) == 0) break;
  }
  out.body = bytes.substr(pos);
  return out;
}

float ReadFloat(const std::string& body, std::size_t offset) {
  float f;
  std::memcpy(&f, body.data() + offset, 4);
  return f;
}
std::int32_t ReadInt(const std::string& body, std::size_t offset) {
  std::int32_t v;
  std::memcpy(&v, body.data() + offset, 4);
  return v;
}

TEST(PointCloudExport, FormatFromExtension) {
  EXPECT_EQ(PointCloudFormatForPath("a/b.ply"), PointCloudFormat::kPly);
  EXPECT_EQ(PointCloudFormatForPath("a/b.PCD"), PointCloudFormat::kPcd);
  EXPECT_FALSE(PointCloudFormatForPath("a/b.xyz").has_value());
  EXPECT_FALSE(PointCloudFormatForPath("ply").has_value());
  EXPECT_THROW(ExportPointCloud(MixedMap(), "/tmp/x.obj", {}), InputError);
}

TEST(PointCloudExport, BinaryPlyHasPointsAndLineSegmentsAsEdges) {
  const slam::Map map = MixedMap();
  PointCloudExportOptions options;
  options.line_length = 2.0;
  PointCloudExportSummary summary;
  const std::string bytes = SerializePly(map, options, &summary);
  const Parsed ply = ParseHeader(bytes, "end_header");
  ASSERT_EQ(ply.all.front(), "ply");
  EXPECT_EQ(ply.lines.at("format"), "binary_little_endian 1.0");
  const std::size_t num_vertices = map.points.size() + 2 * map.lines.size();
  EXPECT_EQ(summary.vertices, num_vertices);
  EXPECT_EQ(summary.edges, map.lines.size());
  EXPECT_NE(
      std::find(ply.all.begin(), ply.all.end(), "element vertex " + std::to_string(num_vertices)),
      ply.all.end());
  EXPECT_NE(
      std::find(ply.all.begin(), ply.all.end(), "element edge " + std::to_string(map.lines.size())),
      ply.all.end());
  const std::size_t vertex_size = 3 * 4 + 3;
  ASSERT_EQ(ply.body.size(), num_vertices * vertex_size + map.lines.size() * 8);
  // Points first, in id order, as float32.
  std::size_t v = 0;
  for (const auto& [id, p] : map.points) {
    for (int a = 0; a < 3; ++a) {
      EXPECT_EQ(ReadFloat(ply.body, v * vertex_size + 4 * a), static_cast<float>(p.position(a)));
    }
    EXPECT_EQ(static_cast<unsigned char>(ply.body[v * vertex_size + 12]), 255);
    ++v;
  }
  // Each edge joins two vertices centred on the line's anchor, line_length apart, along it.
  std::size_t e = 0;
  const std::size_t edges_at = num_vertices * vertex_size;
  for (const auto& [id, l] : map.lines) {
    const std::int32_t a = ReadInt(ply.body, edges_at + 8 * e);
    const std::int32_t b = ReadInt(ply.body, edges_at + 8 * e + 4);
    ++e;
    Eigen::Vector3d pa, pb;
    for (int k = 0; k < 3; ++k) {
      pa(k) = ReadFloat(ply.body, a * vertex_size + 4 * k);
      pb(k) = ReadFloat(ply.body, b * vertex_size + 4 * k);
    }
    const double tolerance = 1e-5 * (1.0 + l.line.anchor.norm());
    EXPECT_LT((0.5 * (pa + pb) - l.line.anchor).norm(), tolerance);
    EXPECT_NEAR((pb - pa).norm(), 2.0, tolerance);
    EXPECT_LT(l.line.Distance(pa), tolerance);
  }
}

TEST(PointCloudExport, AsciiPlyMatchesBinary) {
  const slam::Map map = MixedMap();
  PointCloudExportOptions options;
  options.ascii = true;
  options.include_cameras = true;
  const Parsed ply = ParseHeader(SerializePly(map, options), "end_header");
  EXPECT_EQ(ply.lines.at("format"), "ascii 1.0");
  const std::size_t num_vertices =
      map.points.size() + 2 * map.lines.size() + map.keyframes.size() + map.server_keyframes.size();
  std::istringstream body(ply.body);
  std::vector<Eigen::Vector3f> vertices;
  for (std::size_t i = 0; i < num_vertices; ++i) {
    float x, y, z;
    int r, g, b;
    ASSERT_TRUE(body >> x >> y >> z >> r >> g >> b) << "vertex " << i;
    vertices.emplace_back(x, y, z);
  }
  for (std::size_t i = 0; i < map.lines.size(); ++i) {
    int a, b;
    ASSERT_TRUE(body >> a >> b);
    EXPECT_EQ(b, a + 1);
  }
  std::string rest;
  EXPECT_FALSE(body >> rest);
  // Cameras last: the keyframe centres.
  std::size_t c = map.points.size() + 2 * map.lines.size();
  for (const auto& [id, kf] : map.keyframes) {
    EXPECT_LT((vertices[c++] - kf.cam_from_world.Center().cast<float>()).norm(), 1e-5);
  }
  // The first point read back exactly (9 significant digits round-trip float32).
  EXPECT_EQ(vertices[0], map.points.begin()->second.position.cast<float>());
}

TEST(PointCloudExport, PcdWithPolylines) {
  const slam::Map map = MixedMap();
  PointCloudExportOptions options;
  options.samples_per_line = 5;
  options.line_length = 4.0;
  for (bool ascii : {false, true}) {
    options.ascii = ascii;
    PointCloudExportSummary summary;
    const Parsed pcd = ParseHeader(SerializePcd(map, options, &summary), "DATA");
    const std::size_t count = map.points.size() + 5 * map.lines.size();
    EXPECT_EQ(summary.vertices, count);
    EXPECT_EQ(pcd.lines.at("VERSION"), "0.7");
    EXPECT_EQ(pcd.lines.at("FIELDS"), "x y z rgb");
    EXPECT_EQ(pcd.lines.at("POINTS"), std::to_string(count));
    EXPECT_EQ(pcd.lines.at("WIDTH"), std::to_string(count));
    EXPECT_EQ(pcd.lines.at("DATA"), ascii ? "ascii" : "binary");
    std::vector<Eigen::Vector4f> rows;
    if (ascii) {
      std::istringstream body(pcd.body);
      float x, y, z, rgb;
      while (body >> x >> y >> z >> rgb) rows.emplace_back(x, y, z, rgb);
    } else {
      ASSERT_EQ(pcd.body.size(), count * 16);
      for (std::size_t i = 0; i < count; ++i) {
        rows.emplace_back(ReadFloat(pcd.body, 16 * i), ReadFloat(pcd.body, 16 * i + 4),
                          ReadFloat(pcd.body, 16 * i + 8), ReadFloat(pcd.body, 16 * i + 12));
      }
    }
    ASSERT_EQ(rows.size(), count);
    // Colours as PCL packs them.
    std::uint32_t bits;
    std::memcpy(&bits, &rows[0](3), 4);
    EXPECT_EQ(bits, 0xFFFFFFu & 0xFFFFFF);
    std::memcpy(&bits, &rows[map.points.size()](3), 4);
    EXPECT_EQ(bits, (255u << 16) | (140u << 8));
    // Samples of the first line: evenly spaced along it, centred on the anchor.
    const slam::LineLandmark& line = map.lines.begin()->second;
    for (int s = 0; s < 5; ++s) {
      const Eigen::Vector3d p = rows[map.points.size() + s].head<3>().cast<double>();
      const double tolerance = 1e-5 * (1.0 + line.line.anchor.norm());
      EXPECT_LT(line.line.Distance(p), tolerance);
      EXPECT_NEAR(line.line.Parameter(p) - line.line.Parameter(line.line.anchor), -2.0 + s,
                  tolerance);
    }
  }
}

TEST(PointCloudExport, AutoLineLengthAndFileWrite) {
  const slam::Map map = MixedMap();
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("lcv_export_" + std::to_string(::getpid()) + ".ply"))
                               .string();
  const PointCloudExportSummary summary = ExportPointCloud(map, path, {});
  EXPECT_GT(summary.line_length, 0.1);
  EXPECT_LT(summary.line_length, 10.0);
  const std::string bytes = ReadFileBytes(path);
  EXPECT_EQ(bytes.rfind("ply\n", 0), 0u);
  std::filesystem::remove(path);
  // An empty map still writes a valid (empty) file.
  const Parsed empty = ParseHeader(SerializePly(slam::Map(), {}), "end_header");
  EXPECT_TRUE(empty.body.empty());
}

}  // namespace
}  // namespace lcv::mapping
