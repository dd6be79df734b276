#include "mapping/io/map_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "mapping/io/atomic_file.h"
#include "mapping/io/map_internal.h"
#include "mapping/synthetic_map.h"
#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// A map with every kind of entity and optional field: synthetic keyframes and points, a second
// (fisheye) camera, server keyframes, lines with and without descriptor / restored point /
// client observations.
slam::Map MakeRichMap() {
  SyntheticMapOptions o;
  o.num_points = 40;
  o.num_keyframes = 4;
  o.seed = 21;
  slam::Map map = MakeSyntheticPointMap(o);
  map.description = "rich test map \"quoted\" \xc3\xa9";
  map.points.begin()->second.descriptor.reset();
  slam::Id next = map.NextFreeId();

  slam::CameraParams fisheye;
  fisheye.name = "fisheye";
  fisheye.model = slam::CameraModel::kFisheye;
  fisheye.cols = 1280;
  fisheye.rows = 960;
  fisheye.fx = fisheye.fy = 400.25;
  fisheye.cx = 640.5;
  fisheye.cy = 480.125;
  fisheye.distortion = {0.01, -0.002, 0.0003, -0.00004, 0.0};
  fisheye.fps = 15;
  const slam::Id fisheye_id = next++;
  map.cameras[fisheye_id] = fisheye;

  const slam::Id server_kf_id = next++;
  slam::ServerKeyframe server;
  server.id = server_kf_id;
  server.camera_id = fisheye_id;
  server.timestamp = 12.5;
  server.cam_from_world = slam::Rigid3d(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())),
      Eigen::Vector3d(0.1, -2.0, 3.3));

  for (int i = 0; i < 3; ++i) {
    slam::LineLandmark line;
    line.id = next++;
    line.line.direction = Eigen::Vector3d(1.0 + i, -0.5, 0.25 * i).normalized();
    line.line.anchor = Eigen::Vector3d(0.5 * i, 1.0 / 3.0, -7.0);
    Eigen::Matrix3d cov;
    cov << 0.04, 0.001, 0.0, 0.001, 0.09, 0.002, 0.0, 0.002, 0.25;
    line.information = slam::LineInformation(line.line.direction, cov);
    line.server_keyframe_ids = {server_kf_id};
    server.line_ids.push_back(line.id);
    if (i != 1) {
      slam::OrbDescriptor d;
      for (int b = 0; b < 32; ++b) d[b] = static_cast<std::uint8_t>(b * 7 + i);
      line.descriptor = d;
    }
    if (i == 2) {
      line.restored_point = Eigen::Vector3d(1.25, 2.5, -3.75);
      line.observations = {{2, 0}, {3, 1}};
    }
    map.lines[line.id] = line;
  }
  map.server_keyframes[server_kf_id] = server;
  return map;
}

void ExpectMapsEqual(const slam::Map& a, const slam::Map& b) {
  EXPECT_EQ(a.description, b.description);
  ASSERT_EQ(a.cameras.size(), b.cameras.size());
  for (const auto& [id, c] : a.cameras) {
    const slam::CameraParams& d = b.cameras.at(id);
    EXPECT_EQ(c.name, d.name);
    EXPECT_EQ(c.model, d.model);
    EXPECT_EQ(c.cols, d.cols);
    EXPECT_EQ(c.rows, d.rows);
    EXPECT_EQ(c.fx, d.fx);
    EXPECT_EQ(c.fy, d.fy);
    EXPECT_EQ(c.cx, d.cx);
    EXPECT_EQ(c.cy, d.cy);
    EXPECT_EQ(c.distortion, d.distortion);
    EXPECT_EQ(c.fps, d.fps);
  }
  ASSERT_EQ(a.keyframes.size(), b.keyframes.size());
  for (const auto& [id, kf] : a.keyframes) {
    const slam::Keyframe& other = b.keyframes.at(id);
    EXPECT_EQ(kf.id, other.id);
    EXPECT_EQ(kf.camera_id, other.camera_id);
    EXPECT_EQ(kf.timestamp, other.timestamp);
    EXPECT_EQ(kf.cam_from_world.rotation.coeffs(), other.cam_from_world.rotation.coeffs());
    EXPECT_EQ(kf.cam_from_world.translation, other.cam_from_world.translation);
    ASSERT_EQ(kf.keypoints.size(), other.keypoints.size());
    for (size_t i = 0; i < kf.keypoints.size(); ++i) {
      EXPECT_EQ(kf.keypoints[i].x, other.keypoints[i].x);
      EXPECT_EQ(kf.keypoints[i].y, other.keypoints[i].y);
      EXPECT_EQ(kf.keypoints[i].angle_deg, other.keypoints[i].angle_deg);
      EXPECT_EQ(kf.keypoints[i].octave, other.keypoints[i].octave);
    }
    EXPECT_EQ(kf.descriptors, other.descriptors);
  }
  ASSERT_EQ(a.points.size(), b.points.size());
  for (const auto& [id, p] : a.points) {
    const slam::PointLandmark& q = b.points.at(id);
    EXPECT_EQ(p.position, q.position);
    EXPECT_EQ(p.covariance, q.covariance);
    EXPECT_EQ(p.descriptor, q.descriptor);
    ASSERT_EQ(p.observations.size(), q.observations.size());
    for (size_t i = 0; i < p.observations.size(); ++i) {
      EXPECT_EQ(p.observations[i].keyframe_id, q.observations[i].keyframe_id);
      EXPECT_EQ(p.observations[i].keypoint_index, q.observations[i].keypoint_index);
    }
  }
  ASSERT_EQ(a.lines.size(), b.lines.size());
  for (const auto& [id, l] : a.lines) {
    const slam::LineLandmark& m = b.lines.at(id);
    EXPECT_EQ(l.line.anchor, m.line.anchor);
    EXPECT_EQ(l.line.direction, m.line.direction);
    EXPECT_EQ(l.information, m.information);
    EXPECT_EQ(l.descriptor, m.descriptor);
    EXPECT_EQ(l.server_keyframe_ids, m.server_keyframe_ids);
    EXPECT_EQ(l.restored_point.has_value(), m.restored_point.has_value());
    if (l.restored_point && m.restored_point) {
      EXPECT_EQ(*l.restored_point, *m.restored_point);
    }
    EXPECT_EQ(l.observations.size(), m.observations.size());
  }
  ASSERT_EQ(a.server_keyframes.size(), b.server_keyframes.size());
  for (const auto& [id, kf] : a.server_keyframes) {
    const slam::ServerKeyframe& other = b.server_keyframes.at(id);
    EXPECT_EQ(kf.camera_id, other.camera_id);
    EXPECT_EQ(kf.timestamp, other.timestamp);
    EXPECT_EQ(kf.cam_from_world.rotation.coeffs(), other.cam_from_world.rotation.coeffs());
    EXPECT_EQ(kf.cam_from_world.translation, other.cam_from_world.translation);
    EXPECT_EQ(kf.line_ids, other.line_ids);
  }
}

class TempDir {
 public:
  TempDir() {
    path_ = fs::temp_directory_path() /
            ("lcv_map_file_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter_++));
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string File(const std::string& name) const { return (path_ / name).string(); }
  const fs::path& path() const { return path_; }

 private:
  static inline int counter_ = 0;
  fs::path path_;
};

// Expects ParseMap to throw InputError whose message contains every fragment.
void ExpectRejected(const std::string& bytes, const std::vector<std::string>& fragments) {
  try {
    ParseMap(bytes, "bad.lcmap");
    ADD_FAILURE() << "accepted a bad map; expected: " << fragments.front();
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind("bad.lcmap: ", 0), 0u) << message;
    for (const auto& f : fragments) EXPECT_NE(message.find(f), std::string::npos) << message;
  }
}

// The JSON document of a map, to corrupt one field at a time.
json Document(const slam::Map& map) { return json::parse(SerializeMap(map, MapEncoding::kJson)); }
std::string Text(const json& document) { return document.dump(); }
std::string Pack(const json& document) {
  const auto bytes = json::to_msgpack(document);
  return std::string(bytes.begin(), bytes.end());
}

TEST(MapFile, RoundTripsExactlyInBothEncodings) {
  const slam::Map map = MakeRichMap();
  for (MapEncoding encoding : {MapEncoding::kJson, MapEncoding::kMessagePack}) {
    const std::string bytes = SerializeMap(map, encoding);
    const slam::Map back = ParseMap(bytes, "round trip");
    ExpectMapsEqual(map, back);
    // And stable: serializing the read map gives the same bytes.
    EXPECT_EQ(SerializeMap(back, encoding), bytes);
  }
}

TEST(MapFile, LoopEdgesRoundTripAndAreValidated) {
  slam::Map map = MakeRichMap();
  ASSERT_GE(map.keyframes.size(), 3u);
  auto it = map.keyframes.begin();
  const slam::Id a = (it++)->first, b = (it++)->first, c = it->first;
  map.loop_edges = {{c, a}, {b, a}};
  for (MapEncoding encoding : {MapEncoding::kJson, MapEncoding::kMessagePack}) {
    const std::string bytes = SerializeMap(map, encoding);
    const slam::Map back = ParseMap(bytes, "round trip");
    EXPECT_EQ(back.loop_edges, map.loop_edges);
    EXPECT_EQ(SerializeMap(back, encoding), bytes);
  }
  // A map without loops is written without the key (files stay as they were).
  EXPECT_FALSE(Document(MakeRichMap()).contains("loop_edges"));

  const json good = Document(map);
  json bad = good;
  bad["loop_edges"][1][1] = 999999;
  ExpectRejected(Text(bad), {"/loop_edges/1/1: no keyframe with id 999999"});
  bad = good;
  bad["loop_edges"][0] = json::array({a, a});
  ExpectRejected(Pack(bad), {"/loop_edges/0: a loop edge joins two different keyframes"});
  bad = good;
  bad["loop_edges"][0] = json::array({a});
  ExpectRejected(Text(bad), {"/loop_edges/0: expected 2 numbers"});
  bad = good;
  bad["loop_edges"] = "no";
  ExpectRejected(Text(bad), {"/loop_edges: expected an array"});
}

TEST(MapFile, WritesAtomicallyAndDetectsEncodingFromContent) {
  const slam::Map map = MakeRichMap();
  TempDir dir;
  const std::string json_path = dir.File("map.json");
  const std::string pack_path = dir.File("map.lcmap");
  WriteMap(map, json_path);
  WriteMap(map, pack_path);
  const std::string json_bytes = ReadFileBytes(json_path);
  const std::string pack_bytes = ReadFileBytes(pack_path);
  EXPECT_EQ(json_bytes.rfind("{\n \"magic\": \"lcvmap\",\n \"schema_version\": 1", 0), 0u);
  EXPECT_LT(pack_bytes.size(), json_bytes.size());
  ExpectMapsEqual(map, ReadMap(json_path));
  ExpectMapsEqual(map, ReadMap(pack_path));
  // The content decides, not the name.
  const std::string swapped = dir.File("really_json.lcmap");
  WriteMap(map, swapped, MapEncoding::kJson);
  ExpectMapsEqual(map, ReadMap(swapped));
  // No temporary file left behind.
  int files = 0;
  for (const auto& entry : fs::directory_iterator(dir.path())) {
    ++files;
    EXPECT_EQ(entry.path().string().find(".tmp-"), std::string::npos) << entry.path();
  }
  EXPECT_EQ(files, 3);
  EXPECT_THROW(WriteMap(map, dir.File("missing_folder/map.json")), InputError);
}

TEST(MapFile, EncodingForPath) {
  EXPECT_EQ(EncodingForPath("a/b.json"), MapEncoding::kJson);
  EXPECT_EQ(EncodingForPath("a/b.lcmap"), MapEncoding::kMessagePack);
  EXPECT_EQ(EncodingForPath("json"), MapEncoding::kMessagePack);
}

TEST(MapFile, RejectsFilesThatAreNotMaps) {
  EXPECT_THROW(ReadMap("/nonexistent/folder/map.lcmap"), InputError);
  ExpectRejected("", {"empty file"});
  ExpectRejected("   \n", {"empty file"});
  ExpectRejected("hello", {"not a map file"});
  ExpectRejected("[1, 2]", {"not a map file"});
  ExpectRejected("{\"a\": 1}", {"not an lcv map file"});
  ExpectRejected("{\"magic\": \"lcvmap\", \"schema_version\": 2}",
                 {"schema_version", "2", "not supported"});
  ExpectRejected("{\"magic\": \"lcvmap\", \"schema_version\": \"1\"}", {"not supported"});
  ExpectRejected("{\"magic\": \"lcvmap\"}", {"/schema_version: missing"});
  ExpectRejected("{\"magic\": \"lcvmap\", \"schema_version\": 1,", {"invalid JSON"});
  ExpectRejected(std::string("\x81\xa1\x61\xc1", 4), {"invalid MessagePack", "0xc1"});
  // A minimal valid map is accepted.
  EXPECT_NO_THROW(ParseMap("{\"magic\": \"lcvmap\", \"schema_version\": 1}", "min.json"));
}

TEST(MapFile, RejectsTruncatedFilesInBothEncodings) {
  const slam::Map map = MakeRichMap();
  const std::string text = SerializeMap(map, MapEncoding::kJson);
  const std::string pack = SerializeMap(map, MapEncoding::kMessagePack);
  for (double fraction : {0.1, 0.5, 0.9, 0.999}) {
    ExpectRejected(text.substr(0, static_cast<size_t>(fraction * text.size())), {"invalid JSON"});
    ExpectRejected(pack.substr(0, static_cast<size_t>(fraction * pack.size())),
                   {"invalid MessagePack", "truncated"});
  }
  ExpectRejected(pack + "x", {"trailing bytes"});
}

TEST(MapFile, RejectsDeepNestingWithoutRecursing) {
  // A hostile file: a map whose first value nests a million arrays.
  std::string pack = "\x81\xa1x";
  pack += std::string(1000000, '\x91');
  pack += '\x01';
  ExpectRejected(pack, {"nesting too deep"});
  std::string text = "{\"x\": " + std::string(100000, '[');
  ExpectRejected(text, {"nesting too deep"});
}

TEST(MapFile, NamesThePointerOfTheBadField) {
  const slam::Map map = MakeRichMap();
  const json good = Document(map);
  const size_t num_lines = good["lines"].size();
  ASSERT_EQ(num_lines, 3u);
  struct Case {
    std::function<void(json&)> corrupt;
    std::vector<std::string> fragments;
  };
  const std::vector<Case> cases = {
      {[](json& d) {
         d["lines"][1]["direction"] = json::array({0, 0, 0});
       },
       {"/lines/1/direction: norm 0"}},
      {[](json& d) {
         d["lines"][0]["direction"] = json::array({1, 1, 0});
       },
       {"/lines/0/direction: norm 1.41"}},
      {[](json& d) {
         d["lines"][0]["direction"] = json::array({1, 0});
       },
       {"/lines/0/direction: expected 3 numbers"}},
      {[](json& d) { d["lines"][2]["information"][1] = 5.0; },
       {"/lines/2/information: not symmetric"}},
      {[](json& d) {
         d["lines"][2]["information"] = json::array({-1, 0, 0, 0, 0, 0, 0, 0, 0});
       },
       {"/lines/2/information"}},
      {[](json& d) { d["lines"][0]["anchor"][2] = "abc"; },
       {"/lines/0/anchor/2: expected a number"}},
      {[](json& d) { d["lines"][0]["server_keyframe_ids"][0] = 999999; },
       {"/lines/0/server_keyframe_ids/0: no server keyframe with id 999999"}},
      {[](json& d) { d["lines"][0]["descriptor"] = "abcd"; },
       {"/lines/0/descriptor: expected 64 hex digits"}},
      {[](json& d) { d["lines"][2]["observations"][1][1] = 100000; },
       {"/lines/2/observations/1/1: keypoint index 100000 out of range"}},
      {[](json& d) {
         d["points"][3]["covariance"] = json::array({1, 0, 0, 0, -1, 0, 0, 0, 1});
       },
       {"/points/3/covariance: not positive semi-definite"}},
      {[](json& d) { d["points"][3]["observations"][0][0] = 424242; },
       {"/points/3/observations/0/0: no keyframe with id 424242"}},
      {[](json& d) { d["points"][4]["id"] = d["points"][5]["id"]; }, {"/points/5/id", "duplicate"}},
      {[](json& d) { d["points"][4]["id"] = d["keyframes"][0]["id"]; },
       {"/points/", "/id", "already used by /keyframes/0"}},
      {[](json& d) { d["points"][4]["id"] = -3; },
       {"/points/4/id: expected a non-negative integer"}},
      {[](json& d) { d["points"][4]["id"] = 1.5; },
       {"/points/4/id: expected a non-negative integer"}},
      {[](json& d) { d["points"][0].erase("position"); }, {"/points/0/position: missing"}},
      {[](json& d) { d["keyframes"][1]["camera_id"] = 77777; },
       {"/keyframes/1/camera_id: no camera with id 77777"}},
      {[](json& d) {
         d["keyframes"][1]["cam_from_world"]["rotation_wxyz"] = json::array({1, 1, 0, 0});
       },
       {"/keyframes/1/cam_from_world/rotation_wxyz: norm"}},
      {[](json& d) { d["keyframes"][1]["keypoints"][2][3] = 2.5; },
       {"/keyframes/1/keypoints/2/3: octave"}},
      {[](json& d) { d["keyframes"][1]["keypoints"][2][2] = 400; },
       {"/keyframes/1/keypoints/2/2: angle"}},
      {[](json& d) { d["keyframes"][1]["descriptors"].erase(0); },
       {"/keyframes/1/descriptors", "descriptors for"}},
      {[](json& d) { d["cameras"][0]["fx"] = -1; }, {"/cameras/0", "fx"}},
      {[](json& d) { d["cameras"][0]["model"] = "pinhole"; },
       {"/cameras/0/model: unknown camera model \"pinhole\""}},
      {[](json& d) { d["server_keyframes"][0]["line_ids"][0] = 5555555; },
       {"/server_keyframes/0/line_ids/0: no line with id 5555555"}},
      {[](json& d) { d["lines"] = json::object(); }, {"/lines: expected an array"}},
      {[](json& d) { d["points"][0] = 3; }, {"/points/0: expected an object"}},
  };
  for (const Case& c : cases) {
    json bad = good;
    c.corrupt(bad);
    SCOPED_TRACE(c.fragments.front());
    ExpectRejected(Text(bad), c.fragments);
    ExpectRejected(Pack(bad), c.fragments);
  }
}

// Issue 16 item 4: finite but absurd values (each accepted before, some crashing `lcv render` or
// giving maps the project could not read back) are refused with the pointer of the value.
TEST(MapFile, RejectsImplausibleValuesWithThePointer) {
  const json good = Document(MakeRichMap());
  struct Case {
    std::function<void(json&)> corrupt;
    std::vector<std::string> fragments;
  };
  const std::vector<Case> cases = {
      {[](json& d) { d["cameras"][0]["fx"] = 1e300; }, {"/cameras/0", "fx"}},
      {[](json& d) { d["cameras"][0]["fy"] = 5e-324; }, {"/cameras/0", "fy"}},
      {[](json& d) { d["cameras"][0]["cx"] = 6e21; }, {"/cameras/0", "cx"}},
      {[](json& d) { d["cameras"][0]["distortion"][0] = 1.7e308; }, {"/cameras/0", "k1"}},
      {[](json& d) {
         d["cameras"][0]["cols"] = 100000;
         d["cameras"][0]["rows"] = 1;
       },
       {"/cameras/0", "cols"}},
      {[](json& d) { d["keyframes"][1]["keypoints"][2][0] = -1.4e7; },
       {"/keyframes/1/keypoints/2", "outside"}},
      {[](json& d) { d["lines"][0]["anchor"][1] = 1.4e19; },
       {"/lines/0/anchor/1", "plausible range"}},
      {[](json& d) { d["points"][2]["position"][0] = 1e154; },
       {"/points/2/position/0", "plausible range"}},
      {[](json& d) { d["keyframes"][0]["cam_from_world"]["translation"][2] = -1e308; },
       {"/keyframes/0/cam_from_world/translation/2", "plausible range"}},
      {[](json& d) {
         d["points"][1]["covariance"] = json::array({1e200, 0, 0, 0, 1, 0, 0, 0, 1});
       },
       {"/points/1/covariance/0", "plausible range"}},
  };
  for (const Case& c : cases) {
    json bad = good;
    c.corrupt(bad);
    SCOPED_TRACE(c.fragments.front());
    ExpectRejected(Text(bad), c.fragments);
    ExpectRejected(Pack(bad), c.fragments);
  }
}

TEST(MapFile, RejectsNonFiniteNumbersInMessagePack) {
  // JSON text cannot hold NaN, MessagePack can.
  json bad = Document(MakeRichMap());
  bad["points"][2]["position"][1] = std::nan("");
  ExpectRejected(Pack(bad), {"/points/2/position/1: not a finite number"});
  bad = Document(MakeRichMap());
  bad["keyframes"][0]["timestamp"] = INFINITY;
  ExpectRejected(Pack(bad), {"/keyframes/0/timestamp: not a finite number"});
}

TEST(MapFile, ValidateMapChecksInMemoryMaps) {
  slam::Map map = MakeRichMap();
  EXPECT_NO_THROW(ValidateMap(map, "memory"));
  map.lines.begin()->second.line.direction = Eigen::Vector3d(0, 0, 2);
  try {
    ValidateMap(map, "memory");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("memory: /lines/0/direction: norm 2"), std::string::npos)
        << e.what();
  }
  map = MakeRichMap();
  auto& line = map.lines.begin()->second;
  line.information = Eigen::Matrix3d::Identity();  // d is not in its null space
  EXPECT_THROW(ValidateMap(map, "memory"), InputError);
}

TEST(MapFile, DescriptorHex) {
  slam::OrbDescriptor d;
  for (int i = 0; i < 32; ++i) d[i] = static_cast<std::uint8_t>(255 - 3 * i);
  const std::string hex = internal::DescriptorToHex(d);
  EXPECT_EQ(hex.size(), 64u);
  EXPECT_EQ(hex.substr(0, 4), "fffc");
  slam::OrbDescriptor back{};
  EXPECT_TRUE(internal::DescriptorFromHex(hex, &back));
  EXPECT_EQ(back, d);
  std::string upper = hex;
  for (char& c : upper) c = static_cast<char>(std::toupper(c));
  EXPECT_TRUE(internal::DescriptorFromHex(upper, &back));
  EXPECT_EQ(back, d);
  EXPECT_FALSE(internal::DescriptorFromHex(hex.substr(1), &back));
  EXPECT_FALSE(internal::DescriptorFromHex("g" + hex.substr(1), &back));
}

}  // namespace
}  // namespace lcv::mapping
