// Map files: slam::Map <-> one JSON document, encoded as JSON text or MessagePack
// (docs/map-format.md). Structure and types are checked while decoding, the invariants of
// slam/data/map.h afterwards by ValidateMapAt (map_validate.cc).
#include "mapping/io/map_file.h"

#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>
#include <sstream>

#include "mapping/io/atomic_file.h"
#include "mapping/io/map_internal.h"
#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

using nlohmann::json;
using slam::Id;

constexpr const char* kMagic = "lcvmap";

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
  std::vector<std::uint8_t> bytes = json::to_msgpack(root);
  return std::string(bytes.begin(), bytes.end());
}

// ---------------------------------------------------------------------------------------------
// Decoding: json -> Map, checking structure and types. Paths are built only on failure.

struct Path {
  const Path* parent = nullptr;
  const char* key = nullptr;  // object member, or nullptr for an array index
  std::size_t index = 0;

  Path Key(const char* k) const { return Path{this, k, 0}; }
  Path Index(std::size_t i) const { return Path{this, nullptr, i}; }
  std::string str() const {
    if (!parent) return "";
    return parent->str() + "/" + (key ? std::string(key) : std::to_string(index));
  }
};

class Decoder {
 public:
  explicit Decoder(const std::string& source) : source_(source) {}

  [[noreturn]] void Fail(const Path& at, const std::string& what) const {
    const std::string pointer = at.str();
    throw InputError(source_, (pointer.empty() ? std::string("(root)") : pointer) + ": " + what);
  }

  static std::string Describe(const json& j) {
    std::string text =
        j.is_binary() ? "binary data" : j.dump(-1, ' ', false, json::error_handler_t::replace);
    if (text.size() > 40) text = text.substr(0, 37) + "...";
    return text;
  }

  const json& Field(const json& object, const Path& at, const char* key) const {
    const auto it = object.find(key);
    if (it == object.end()) Fail(at.Key(key), "missing");
    return *it;
  }
  const json* OptionalField(const json& object, const char* key) const {
    const auto it = object.find(key);
    return it == object.end() || it->is_null() ? nullptr : &*it;
  }

  const json& Object(const json& j, const Path& at) const {
    if (!j.is_object()) Fail(at, "expected an object, got " + Describe(j));
    return j;
  }
  const json& Array(const json& j, const Path& at, std::size_t expected_size = 0) const {
    if (!j.is_array()) Fail(at, "expected an array, got " + Describe(j));
    if (expected_size && j.size() != expected_size) {
      Fail(at, "expected " + std::to_string(expected_size) + " numbers, got " +
                   std::to_string(j.size()));
    }
    return j;
  }

  double Number(const json& j, const Path& at) const {
    if (!j.is_number()) Fail(at, "expected a number, got " + Describe(j));
    const double value = j.get<double>();
    if (!std::isfinite(value)) Fail(at, "not a finite number");
    return value;
  }
  std::uint64_t Unsigned(const json& j, const Path& at, std::uint64_t max) const {
    if (!j.is_number_unsigned()) {
      Fail(at, "expected a non-negative integer, got " + Describe(j));
    }
    const std::uint64_t value = j.get<std::uint64_t>();
    if (value > max) Fail(at, "integer " + std::to_string(value) + " too large");
    return value;
  }
  Id Identifier(const json& j, const Path& at) const {
    return Unsigned(j, at, std::numeric_limits<Id>::max());
  }
  std::string String(const json& j, const Path& at) const {
    if (!j.is_string()) Fail(at, "expected a string, got " + Describe(j));
    return j.get<std::string>();
  }

  template <int N>
  Eigen::Matrix<double, N, 1> Vector(const json& j, const Path& at) const {
    Array(j, at, N);
    Eigen::Matrix<double, N, 1> v;
    for (int i = 0; i < N; ++i) v(i) = Number(j[i], at.Index(i));
    return v;
  }
  Eigen::Matrix3d Matrix3(const json& j, const Path& at) const {
    const Eigen::Matrix<double, 9, 1> v = Vector<9>(j, at);
    Eigen::Matrix3d m;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) m(r, c) = v(3 * r + c);
    }
    return m;
  }
  slam::Rigid3d Pose(const json& j, const Path& at) const {
    Object(j, at);
    const Path rotation_at = at.Key("rotation_wxyz");
    const Eigen::Vector4d wxyz = Vector<4>(Field(j, at, "rotation_wxyz"), rotation_at);
    if (wxyz.norm() == 0.0) Fail(rotation_at, "norm 0");
    const Eigen::Vector3d translation =
        Vector<3>(Field(j, at, "translation"), at.Key("translation"));
    // Not normalized here: the validator rejects a quaternion that is not unit.
    return slam::Rigid3d(Eigen::Quaterniond(wxyz(0), wxyz(1), wxyz(2), wxyz(3)), translation);
  }
  slam::OrbDescriptor Descriptor(const json& j, const Path& at) const {
    slam::OrbDescriptor d{};
    if (j.is_binary()) {
      if (j.get_binary().size() != d.size()) {
        Fail(at, "expected 32 bytes, got " + std::to_string(j.get_binary().size()));
      }
      std::memcpy(d.data(), j.get_binary().data(), d.size());
      return d;
    }
    if (!j.is_string() || !internal::DescriptorFromHex(j.get_ref<const std::string&>(), &d)) {
      Fail(at, "expected 64 hex digits or 32 bytes, got " + Describe(j));
    }
    return d;
  }
  std::vector<slam::Observation> Observations(const json* j, const Path& at) const {
    std::vector<slam::Observation> out;
    if (!j) return out;
    Array(*j, at);
    out.reserve(j->size());
    for (std::size_t i = 0; i < j->size(); ++i) {
      const Path obs_at = at.Index(i);
      const json& obs = Array((*j)[i], obs_at, 2);
      out.push_back({Identifier(obs[0], obs_at.Index(0)),
                     static_cast<std::uint32_t>(Unsigned(
                         obs[1], obs_at.Index(1), std::numeric_limits<std::uint32_t>::max()))});
    }
    return out;
  }
  std::vector<Id> Ids(const json* j, const Path& at) const {
    std::vector<Id> out;
    if (!j) return out;
    Array(*j, at);
    out.reserve(j->size());
    for (std::size_t i = 0; i < j->size(); ++i) out.push_back(Identifier((*j)[i], at.Index(i)));
    return out;
  }

  // Inserts value under id, failing on a duplicate; records the array index for messages.
  template <typename T>
  void Insert(std::map<Id, T>* container, std::map<Id, std::size_t>* locator, Id id, T value,
              const Path& at) const {
    if (!container->emplace(id, std::move(value)).second) {
      Fail(at.Key("id"), "duplicate id " + std::to_string(id));
    }
    (*locator)[id] = at.index;
  }

 private:
  const std::string& source_;
};

slam::CameraParams DecodeCamera(const Decoder& d, const json& j, const Path& at) {
  slam::CameraParams c;
  if (const json* name = d.OptionalField(j, "name")) c.name = d.String(*name, at.Key("name"));
  const std::string model = d.String(d.Field(j, at, "model"), at.Key("model"));
  const auto parsed = slam::ParseCameraModel(model);
  if (!parsed) {
    d.Fail(at.Key("model"),
           "unknown camera model \"" + model + "\" (perspective, fisheye, equirectangular)");
  }
  c.model = *parsed;
  c.cols = static_cast<int>(d.Unsigned(d.Field(j, at, "cols"), at.Key("cols"), 1 << 20));
  c.rows = static_cast<int>(d.Unsigned(d.Field(j, at, "rows"), at.Key("rows"), 1 << 20));
  for (auto [key, field] : {std::pair<const char*, double*>{"fx", &c.fx},
                            {"fy", &c.fy},
                            {"cx", &c.cx},
                            {"cy", &c.cy}}) {
    *field = d.Number(d.Field(j, at, key), at.Key(key));
  }
  if (const json* distortion = d.OptionalField(j, "distortion")) {
    const Eigen::Matrix<double, 5, 1> k = d.Vector<5>(*distortion, at.Key("distortion"));
    for (int i = 0; i < 5; ++i) c.distortion[i] = k(i);
  }
  if (const json* fps = d.OptionalField(j, "fps")) c.fps = d.Number(*fps, at.Key("fps"));
  return c;
}

slam::Keyframe DecodeKeyframe(const Decoder& d, const json& j, const Path& at) {
  slam::Keyframe kf;
  kf.id = d.Identifier(d.Field(j, at, "id"), at.Key("id"));
  kf.camera_id = d.Identifier(d.Field(j, at, "camera_id"), at.Key("camera_id"));
  kf.timestamp = d.Number(d.Field(j, at, "timestamp"), at.Key("timestamp"));
  kf.cam_from_world = d.Pose(d.Field(j, at, "cam_from_world"), at.Key("cam_from_world"));
  if (const json* keypoints = d.OptionalField(j, "keypoints")) {
    const Path kps_at = at.Key("keypoints");
    d.Array(*keypoints, kps_at);
    kf.keypoints.reserve(keypoints->size());
    for (std::size_t i = 0; i < keypoints->size(); ++i) {
      const Path kp_at = kps_at.Index(i);
      const Eigen::Vector4d v = d.Vector<4>((*keypoints)[i], kp_at);
      slam::Keypoint kp;
      kp.x = static_cast<float>(v(0));
      kp.y = static_cast<float>(v(1));
      kp.angle_deg = static_cast<float>(v(2));
      if (v(3) != std::floor(v(3)) || v(3) < 0 || v(3) > 63) {
        d.Fail(kp_at.Index(3), "octave must be an integer in [0, 63]");
      }
      kp.octave = static_cast<int>(v(3));
      kf.keypoints.push_back(kp);
    }
  }
  if (const json* descriptors = d.OptionalField(j, "descriptors")) {
    const Path ds_at = at.Key("descriptors");
    d.Array(*descriptors, ds_at);
    kf.descriptors.reserve(descriptors->size());
    for (std::size_t i = 0; i < descriptors->size(); ++i) {
      kf.descriptors.push_back(d.Descriptor((*descriptors)[i], ds_at.Index(i)));
    }
  }
  return kf;
}

slam::PointLandmark DecodePoint(const Decoder& d, const json& j, const Path& at) {
  slam::PointLandmark p;
  p.id = d.Identifier(d.Field(j, at, "id"), at.Key("id"));
  p.position = d.Vector<3>(d.Field(j, at, "position"), at.Key("position"));
  p.covariance = d.Matrix3(d.Field(j, at, "covariance"), at.Key("covariance"));
  if (const json* desc = d.OptionalField(j, "descriptor")) {
    p.descriptor = d.Descriptor(*desc, at.Key("descriptor"));
  }
  p.observations = d.Observations(d.OptionalField(j, "observations"), at.Key("observations"));
  return p;
}

slam::LineLandmark DecodeLine(const Decoder& d, const json& j, const Path& at) {
  slam::LineLandmark l;
  l.id = d.Identifier(d.Field(j, at, "id"), at.Key("id"));
  l.line.anchor = d.Vector<3>(d.Field(j, at, "anchor"), at.Key("anchor"));
  l.line.direction = d.Vector<3>(d.Field(j, at, "direction"), at.Key("direction"));
  l.information = d.Matrix3(d.Field(j, at, "information"), at.Key("information"));
  if (const json* desc = d.OptionalField(j, "descriptor")) {
    l.descriptor = d.Descriptor(*desc, at.Key("descriptor"));
  }
  l.server_keyframe_ids =
      d.Ids(d.OptionalField(j, "server_keyframe_ids"), at.Key("server_keyframe_ids"));
  if (const json* restored = d.OptionalField(j, "restored_point")) {
    l.restored_point = d.Vector<3>(*restored, at.Key("restored_point"));
  }
  l.observations = d.Observations(d.OptionalField(j, "observations"), at.Key("observations"));
  return l;
}

slam::ServerKeyframe DecodeServerKeyframe(const Decoder& d, const json& j, const Path& at) {
  slam::ServerKeyframe kf;
  kf.id = d.Identifier(d.Field(j, at, "id"), at.Key("id"));
  kf.camera_id = d.Identifier(d.Field(j, at, "camera_id"), at.Key("camera_id"));
  kf.timestamp = d.Number(d.Field(j, at, "timestamp"), at.Key("timestamp"));
  kf.cam_from_world = d.Pose(d.Field(j, at, "cam_from_world"), at.Key("cam_from_world"));
  kf.line_ids = d.Ids(d.OptionalField(j, "line_ids"), at.Key("line_ids"));
  return kf;
}

template <typename T, typename DecodeOne>
void DecodeSection(const Decoder& d, const json& root, const Path& root_at, const char* name,
                   std::map<Id, T>* container, std::map<Id, std::size_t>* locator,
                   DecodeOne decode_one) {
  const json* section = d.OptionalField(root, name);
  if (!section) return;
  const Path at = root_at.Key(name);
  d.Array(*section, at);
  for (std::size_t i = 0; i < section->size(); ++i) {
    const Path element_at = at.Index(i);
    const json& element = d.Object((*section)[i], element_at);
    T value = decode_one(d, element, element_at);
    // Cameras carry their id beside the parameters.
    Id id;
    if constexpr (std::is_same_v<T, slam::CameraParams>) {
      id = d.Identifier(d.Field(element, element_at, "id"), element_at.Key("id"));
    } else {
      id = value.id;
    }
    d.Insert(container, locator, id, std::move(value), element_at);
  }
}

json DecodeDocument(const std::string& bytes, const std::string& source) {
  std::size_t first = 0;
  while (first < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[first]))) ++first;
  if (first == bytes.size()) throw InputError(source, "empty file, not a map");
  const auto lead = static_cast<unsigned char>(bytes[first]);
  const bool is_json = lead == '{';
  const bool is_msgpack = first == 0 && ((lead & 0xf0) == 0x80 || lead == 0xde || lead == 0xdf);
  if (!is_json && !is_msgpack) {
    throw InputError(source, "not a map file (neither a JSON object nor a MessagePack map)");
  }
  try {
    if (is_json) {
      internal::CheckJsonNesting(bytes, source);
      return json::parse(bytes);
    }
    internal::CheckMessagePackStructure(bytes, source);
    return json::from_msgpack(bytes, /*strict=*/true);
  } catch (const json::exception& e) {
    // "[json.exception.parse_error.101] parse error at line 3, column 7: ..." -> drop the tag.
    std::string what = e.what();
    const std::size_t tag_end = what.find("] ");
    if (tag_end != std::string::npos) what = what.substr(tag_end + 2);
    throw InputError(source,
                     std::string(is_json ? "invalid JSON: " : "invalid MessagePack: ") + what);
  }
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

slam::Map ParseMap(const std::string& bytes, const std::string& source_name) {
  const json root = DecodeDocument(bytes, source_name);
  const Decoder d(source_name);
  const Path root_at;
  if (!root.is_object()) d.Fail(root_at, "expected an object");
  // Magic and version before anything else: a different file or a newer schema is named as such
  // instead of failing on some field.
  const json* magic = d.OptionalField(root, "magic");
  if (!magic || !magic->is_string() || magic->get_ref<const std::string&>() != kMagic) {
    throw InputError(source_name, "not an lcv map file (no \"magic\": \"lcvmap\")");
  }
  const json& version = d.Field(root, root_at, "schema_version");
  if (!version.is_number_integer() || version.get<std::int64_t>() != kMapSchemaVersion) {
    d.Fail(root_at.Key("schema_version"), "schema version " + Decoder::Describe(version) +
                                              " is not supported (this build reads " +
                                              std::to_string(kMapSchemaVersion) + ")");
  }

  slam::Map map;
  internal::EntityLocator locator;
  try {
    if (const json* description = d.OptionalField(root, "description")) {
      map.description = d.String(*description, root_at.Key("description"));
    }
    DecodeSection(d, root, root_at, "cameras", &map.cameras, &locator.cameras, DecodeCamera);
    DecodeSection(d, root, root_at, "keyframes", &map.keyframes, &locator.keyframes,
                  DecodeKeyframe);
    DecodeSection(d, root, root_at, "points", &map.points, &locator.points, DecodePoint);
    DecodeSection(d, root, root_at, "lines", &map.lines, &locator.lines, DecodeLine);
    DecodeSection(d, root, root_at, "server_keyframes", &map.server_keyframes,
                  &locator.server_keyframes, DecodeServerKeyframe);
  } catch (const json::exception& e) {
    // Defence in depth: the decoder checks types before every access, so this is not expected.
    throw InputError(source_name, std::string("malformed map: ") + e.what());
  }

  internal::ValidateMapAt(map, source_name, locator);
  // Within tolerance of unit now. Values written with fewer digits are made unit; values already
  // unit to rounding are left bit-exact so that a map round-trips unchanged.
  auto renormalize = [](auto& v) {
    if (std::abs(v.squaredNorm() - 1.0) > 1e-14) v.normalize();
  };
  for (auto& [id, kf] : map.keyframes) renormalize(kf.cam_from_world.rotation.coeffs());
  for (auto& [id, kf] : map.server_keyframes) renormalize(kf.cam_from_world.rotation.coeffs());
  for (auto& [id, line] : map.lines) renormalize(line.line.direction);
  return map;
}

slam::Map ReadMap(const std::string& path) { return ParseMap(ReadFileBytes(path), path); }

std::string SerializeMap(const slam::Map& map, MapEncoding encoding) {
  return encoding == MapEncoding::kJson ? SerializeJson(map) : SerializeMessagePack(map);
}

void WriteMap(const slam::Map& map, const std::string& path, MapEncoding encoding) {
  WriteFileAtomically(path, SerializeMap(map, encoding));
}

void WriteMap(const slam::Map& map, const std::string& path) {
  WriteMap(map, path, EncodingForPath(path));
}

}  // namespace lcv::mapping
