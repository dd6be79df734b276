// Map files: slam::Map <-> one JSON document, encoded as JSON text or MessagePack
// (docs/map-format.md). Structure and types are checked while decoding, the invariants of
// slam/data/map.h afterwards by ValidateMapAt (map_validate.cc). Decoding is in map_decoder.cc.
#include "mapping/io/map_file.h"

#include <cctype>
#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string_view>

#include "mapping/io/atomic_file.h"
#include "mapping/io/map_decoder.h"
#include "mapping/io/map_internal.h"
#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

using nlohmann::json;
using slam::Id;

constexpr const char* kMagic = internal::kMapMagic;

// ---------------------------------------------------------------------------------------------
// Encoding: Map -> json.

json Vector3ToJson(const Eigen::Vector3d& v) { return json::array({v.x(), v.y(), v.z()}); }

json Matrix3ToJson(const Eigen::Matrix3d& m) {
  json out = json::array();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out.push_back(m(r, c));
  }
  return out;
}

json PoseToJson(const slam::Rigid3d& pose) {
  const Eigen::Quaterniond& q = pose.rotation;
  return json{{"rotation_wxyz", json::array({q.w(), q.x(), q.y(), q.z()})},
              {"translation", Vector3ToJson(pose.translation)}};
}

// Hex text in JSON (readable), raw bytes in MessagePack (compact).
json DescriptorToJson(const slam::OrbDescriptor& d, bool binary) {
  if (binary) return json::binary(std::vector<std::uint8_t>(d.begin(), d.end()));
  return internal::DescriptorToHex(d);
}

json ObservationsToJson(const std::vector<slam::Observation>& observations) {
  json out = json::array();
  for (const slam::Observation& obs : observations) {
    out.push_back(json::array({obs.keyframe_id, obs.keypoint_index}));
  }
  return out;
}

json CameraToJson(Id id, const slam::CameraParams& c) {
  return json{{"id", id},
              {"name", c.name},
              {"model", slam::CameraModelName(c.model)},
              {"cols", c.cols},
              {"rows", c.rows},
              {"fx", c.fx},
              {"fy", c.fy},
              {"cx", c.cx},
              {"cy", c.cy},
              {"distortion", json(std::vector<double>(c.distortion.begin(), c.distortion.end()))},
              {"fps", c.fps}};
}

json KeyframeToJson(const slam::Keyframe& kf, bool binary) {
  json keypoints = json::array();
  for (const slam::Keypoint& kp : kf.keypoints) {
    keypoints.push_back(json::array({kp.x, kp.y, kp.angle_deg, kp.octave}));
  }
  json descriptors = json::array();
  for (const auto& d : kf.descriptors) descriptors.push_back(DescriptorToJson(d, binary));
  return json{{"id", kf.id},
              {"camera_id", kf.camera_id},
              {"timestamp", kf.timestamp},
              {"cam_from_world", PoseToJson(kf.cam_from_world)},
              {"keypoints", std::move(keypoints)},
              {"descriptors", std::move(descriptors)}};
}

json PointToJson(const slam::PointLandmark& p, bool binary) {
  json out{{"id", p.id},
           {"position", Vector3ToJson(p.position)},
           {"covariance", Matrix3ToJson(p.covariance)},
           {"observations", ObservationsToJson(p.observations)}};
  if (p.descriptor) out["descriptor"] = DescriptorToJson(*p.descriptor, binary);
  return out;
}

json LineToJson(const slam::LineLandmark& l, bool binary) {
  json out{{"id", l.id},
           {"anchor", Vector3ToJson(l.line.anchor)},
           {"direction", Vector3ToJson(l.line.direction)},
           {"information", Matrix3ToJson(l.information)},
           {"server_keyframe_ids", l.server_keyframe_ids}};
  if (l.descriptor) out["descriptor"] = DescriptorToJson(*l.descriptor, binary);
  if (l.restored_point) out["restored_point"] = Vector3ToJson(*l.restored_point);
  if (!l.observations.empty()) out["observations"] = ObservationsToJson(l.observations);
  return out;
}

json ServerKeyframeToJson(const slam::ServerKeyframe& kf) {
  return json{{"id", kf.id},
              {"camera_id", kf.camera_id},
              {"timestamp", kf.timestamp},
              {"cam_from_world", PoseToJson(kf.cam_from_world)},
              {"line_ids", kf.line_ids}};
}

// The containers of the document in file order, each element built on demand so that the JSON
// writer can stream one line per entity.
template <typename Visit>
void ForEachSection(const slam::Map& map, bool binary, Visit&& visit) {
  visit("cameras", map.cameras.size(), [&](auto&& emit) {
    for (const auto& [id, c] : map.cameras) emit(CameraToJson(id, c));
  });
  visit("keyframes", map.keyframes.size(), [&](auto&& emit) {
    for (const auto& [id, kf] : map.keyframes) emit(KeyframeToJson(kf, binary));
  });
  visit("points", map.points.size(), [&](auto&& emit) {
    for (const auto& [id, p] : map.points) emit(PointToJson(p, binary));
  });
  visit("lines", map.lines.size(), [&](auto&& emit) {
    for (const auto& [id, l] : map.lines) emit(LineToJson(l, binary));
  });
  visit("server_keyframes", map.server_keyframes.size(), [&](auto&& emit) {
    for (const auto& [id, kf] : map.server_keyframes) emit(ServerKeyframeToJson(kf));
  });
}

// Compact JSON; invalid UTF-8 in names is replaced rather than failing the whole write.
std::string Dump(const json& j) { return j.dump(-1, ' ', false, json::error_handler_t::replace); }

// JSON text with magic and version first and one entity per line: readable and diffable
// without the size of a fully indented dump.
std::string SerializeJson(const slam::Map& map) {
  std::ostringstream out;
  out << "{\n \"magic\": \"" << kMagic << "\",\n \"schema_version\": " << kMapSchemaVersion
      << ",\n \"description\": " << Dump(json(map.description));
  ForEachSection(map, false, [&](const char* name, std::size_t size, auto&& produce) {
    out << ",\n \"" << name << "\": [";
    bool first = true;
    produce([&](const json& element) {
      out << (first ? "\n  " : ",\n  ") << Dump(element);
      first = false;
    });
    out << (size ? "\n ]" : "]");
  });
  if (!map.loop_edges.empty()) out << ",\n \"loop_edges\": " << Dump(json(map.loop_edges));
  out << "\n}\n";
  return out.str();
}

std::string SerializeMessagePack(const slam::Map& map) {
  json root{
      {"magic", kMagic}, {"schema_version", kMapSchemaVersion}, {"description", map.description}};
  ForEachSection(map, true, [&](const char* name, std::size_t, auto&& produce) {
    json array = json::array();
    produce([&](json element) { array.push_back(std::move(element)); });
    root[name] = std::move(array);
  });
  if (!map.loop_edges.empty()) root["loop_edges"] = map.loop_edges;
  std::vector<std::uint8_t> bytes = json::to_msgpack(root);
  return std::string(bytes.begin(), bytes.end());
}

}  // namespace

namespace internal {

std::string DescriptorToHex(const slam::OrbDescriptor& descriptor) {
  static const char kDigits[] = "0123456789abcdef";
  std::string hex(64, '0');
  for (int i = 0; i < 32; ++i) {
    hex[2 * i] = kDigits[descriptor[i] >> 4];
    hex[2 * i + 1] = kDigits[descriptor[i] & 15];
  }
  return hex;
}

bool DescriptorFromHex(const std::string& hex, slam::OrbDescriptor* descriptor) {
  if (hex.size() != 64) return false;
  auto nibble = [](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
  };
  for (int i = 0; i < 32; ++i) {
    const int hi = nibble(hex[2 * i]), lo = nibble(hex[2 * i + 1]);
    if (hi < 0 || lo < 0) return false;
    (*descriptor)[i] = static_cast<std::uint8_t>(hi << 4 | lo);
  }
  return true;
}

}  // namespace internal

MapEncoding EncodingForPath(const std::string& path) {
  const std::string suffix = ".json";
  const bool is_json = path.size() >= suffix.size() &&
                       path.compare(path.size() - suffix.size(), suffix.size(), suffix) == 0;
  return is_json ? MapEncoding::kJson : MapEncoding::kMessagePack;
}

namespace {

// 0 when bytes do not start like a map, '{' for JSON, 'm' for MessagePack, ' ' when they are
// blank so far. Blank runs longer than a head are refused by the caller.
char MapLead(std::string_view bytes) {
  std::size_t first = 0;
  while (first < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[first]))) ++first;
  if (first == bytes.size()) return ' ';
  const auto lead = static_cast<unsigned char>(bytes[first]);
  if (lead == '{') return '{';
  if (first == 0 && ((lead & 0xf0) == 0x80 || lead == 0xde || lead == 0xdf)) return 'm';
  return 0;
}

constexpr const char* kNotAMap = "not a map file (neither a JSON object nor a MessagePack map)";

}  // namespace

slam::Map ParseMap(const std::string& bytes, const std::string& source_name) {
  switch (MapLead(bytes)) {
    case ' ':
      throw InputError(source_name, "empty file, not a map");
    case '{':
      return internal::ParseJsonMap(bytes, source_name);
    case 'm':
      return internal::ParseMessagePackMap(bytes, source_name);
    default:
      throw InputError(source_name, kNotAMap);
  }
}

std::string ReadMapBytes(const std::string& path) {
  return ReadFileBytesChecked(path, kMaxInputFileBytes, [&](std::string_view head) {
    const char lead = MapLead(head);
    // A head that is blank throughout and as long as a head can be: no map starts like that.
    if (lead == 0 || (lead == ' ' && head.size() >= (std::size_t{1} << 16))) {
      throw InputError(path, kNotAMap);
    }
  });
}

slam::Map ReadMap(const std::string& path) { return ParseMap(ReadMapBytes(path), path); }

std::string SerializeMap(const slam::Map& map, MapEncoding encoding) {
  return encoding == MapEncoding::kJson ? SerializeJson(map) : SerializeMessagePack(map);
}

void WriteMap(const slam::Map& map, const std::string& path, MapEncoding encoding) {
  // Every map written must read back (issue 16: a map with an infinite covariance was written,
  // exit 0, and then refused by every command): the reader's checks run first.
  ValidateMap(map, path + ": not written, the map would not read back");
  WriteFileAtomically(path, SerializeMap(map, encoding));
}

void WriteMap(const slam::Map& map, const std::string& path) {
  WriteMap(map, path, EncodingForPath(path));
}

}  // namespace lcv::mapping
