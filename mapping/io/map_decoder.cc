// Map documents -> slam::Map, checking structure and types (paths are built only on failure),
// then the invariants of slam/data/map.h (ValidateMapAt, map_validate.cc).
//
// The decoder runs on value handles with one interface (is_*(), size(), as_double(),
// as_unsigned(), as_integer(), bytes(), MembersOf(), ForEachElement(), Describe()): JsonValue over
// nlohmann-json's DOM for JSON text, MsgpackValue (msgpack_value.h) straight over the bytes of a
// MessagePack file, where a DOM would cost ~0.7 s of CPU per 30 MB map.
#include "mapping/io/map_decoder.h"

#include <cmath>
#include <cstring>
#include <limits>
#include <nlohmann/json.hpp>
#include <string_view>
#include <type_traits>

#include "mapping/io/map_file.h"
#include "mapping/io/map_internal.h"
#include "mapping/io/msgpack_value.h"
#include "slam/util/error.h"

namespace lcv::mapping::internal {
namespace {

using nlohmann::json;
using slam::Id;

// A handle to a node of a nlohmann-json DOM, with MsgpackValue's interface.
class JsonValue {
 public:
  JsonValue() = default;
  explicit JsonValue(const json* j) : j_(j) {}
  bool valid() const { return j_ != nullptr; }
  bool is_null() const { return j_->is_null(); }
  bool is_object() const { return j_->is_object(); }
  bool is_array() const { return j_->is_array(); }
  bool is_string() const { return j_->is_string(); }
  bool is_binary() const { return j_->is_binary(); }
  bool is_number() const { return j_->is_number(); }
  bool is_number_unsigned() const { return j_->is_number_unsigned(); }
  bool is_number_integer() const { return j_->is_number_integer(); }
  std::uint64_t size() const { return is_array() || is_object() ? j_->size() : 0; }
  double as_double() const { return j_->get<double>(); }
  std::uint64_t as_unsigned() const { return j_->get<std::uint64_t>(); }
  std::int64_t as_integer() const { return j_->get<std::int64_t>(); }
  std::string_view bytes() const {
    if (is_binary()) {
      const auto& b = j_->get_binary();
      return std::string_view(reinterpret_cast<const char*>(b.data()), b.size());
    }
    return j_->get_ref<const std::string&>();
  }
  // An object's members, for repeated lookups (MsgpackValue::Members' interface).
  class Members {
   public:
    explicit Members(const json* j) : j_(j) {}
    JsonValue Find(const char* key) const {
      const auto it = j_->find(key);
      return it == j_->end() ? JsonValue() : JsonValue(&*it);
    }

   private:
    const json* j_;
  };
  Members MembersOf() const { return Members(j_); }
  template <typename F>
  void ForEachElement(F&& f) const {
    for (const json& element : *j_) f(JsonValue(&element));
  }
  std::string Describe(std::size_t) const {
    return j_->dump(-1, ' ', false, json::error_handler_t::replace);
  }

 private:
  const json* j_ = nullptr;
};

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

template <typename V>
class Decoder {
 public:
  explicit Decoder(const std::string& source) : source_(source) {}

  [[noreturn]] void Fail(const Path& at, const std::string& what) const {
    const std::string pointer = at.str();
    throw InputError(source_, (pointer.empty() ? std::string("(root)") : pointer) + ": " + what);
  }

  static std::string Describe(const V& j) {
    std::string text = j.is_binary() ? "binary data" : j.Describe(40);
    if (text.size() > 40) text = text.substr(0, 37) + "...";
    return text;
  }

  using Members = typename V::Members;
  // object: the members of an object (V::MembersOf), collected once per object.
  V Field(const Members& object, const Path& at, const char* key) const {
    const V member = object.Find(key);
    if (!member.valid()) Fail(at.Key(key), "missing");
    return member;
  }
  // Invalid (valid() false) when absent or null.
  V OptionalField(const Members& object, const char* key) const {
    const V member = object.Find(key);
    return member.valid() && !member.is_null() ? member : V();
  }

  void Object(const V& j, const Path& at) const {
    if (!j.is_object()) Fail(at, "expected an object, got " + Describe(j));
  }
  void Array(const V& j, const Path& at, std::size_t expected_size = 0) const {
    if (!j.is_array()) Fail(at, "expected an array, got " + Describe(j));
    if (expected_size && j.size() != expected_size) {
      Fail(at, "expected " + std::to_string(expected_size) + " numbers, got " +
                   std::to_string(j.size()));
    }
  }
  // f(element, path) for each element of an array (checked).
  template <typename F>
  void Elements(const V& j, const Path& at, F&& f) const {
    Array(j, at);
    std::size_t i = 0;
    j.ForEachElement([&](const V& element) { f(element, at.Index(i++)); });
  }

  double Number(const V& j, const Path& at) const {
    if (!j.is_number()) Fail(at, "expected a number, got " + Describe(j));
    const double value = j.as_double();
    if (!std::isfinite(value)) Fail(at, "not a finite number");
    return value;
  }
  std::uint64_t Unsigned(const V& j, const Path& at, std::uint64_t max) const {
    if (!j.is_number_unsigned()) {
      Fail(at, "expected a non-negative integer, got " + Describe(j));
    }
    const std::uint64_t value = j.as_unsigned();
    if (value > max) Fail(at, "integer " + std::to_string(value) + " too large");
    return value;
  }
  Id Identifier(const V& j, const Path& at) const {
    return Unsigned(j, at, std::numeric_limits<Id>::max());
  }
  std::string String(const V& j, const Path& at) const {
    if (!j.is_string()) Fail(at, "expected a string, got " + Describe(j));
    return std::string(j.bytes());
  }

  template <int N>
  Eigen::Matrix<double, N, 1> Vector(const V& j, const Path& at) const {
    Array(j, at, N);
    Eigen::Matrix<double, N, 1> v;
    int i = 0;
    j.ForEachElement([&](const V& element) {
      v(i) = Number(element, at.Index(i));
      ++i;
    });
    return v;
  }
  Eigen::Matrix3d Matrix3(const V& j, const Path& at) const {
    const Eigen::Matrix<double, 9, 1> v = Vector<9>(j, at);
    Eigen::Matrix3d m;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) m(r, c) = v(3 * r + c);
    }
    return m;
  }
  slam::Rigid3d Pose(const V& pose, const Path& at) const {
    Object(pose, at);
    const Members j = pose.MembersOf();
    const Path rotation_at = at.Key("rotation_wxyz");
    const Eigen::Vector4d wxyz = Vector<4>(Field(j, at, "rotation_wxyz"), rotation_at);
    if (wxyz.norm() == 0.0) Fail(rotation_at, "norm 0");
    const Eigen::Vector3d translation =
        Vector<3>(Field(j, at, "translation"), at.Key("translation"));
    // Not normalized here: the validator rejects a quaternion that is not unit.
    return slam::Rigid3d(Eigen::Quaterniond(wxyz(0), wxyz(1), wxyz(2), wxyz(3)), translation);
  }
  slam::OrbDescriptor Descriptor(const V& j, const Path& at) const {
    slam::OrbDescriptor d{};
    if (j.is_binary()) {
      const std::string_view bytes = j.bytes();
      if (bytes.size() != d.size()) {
        Fail(at, "expected 32 bytes, got " + std::to_string(bytes.size()));
      }
      std::memcpy(d.data(), bytes.data(), d.size());
      return d;
    }
    if (!j.is_string() || !DescriptorFromHex(std::string(j.bytes()), &d)) {
      Fail(at, "expected 64 hex digits or 32 bytes, got " + Describe(j));
    }
    return d;
  }
  std::vector<slam::Observation> Observations(const V& j, const Path& at) const {
    std::vector<slam::Observation> out;
    if (!j.valid()) return out;
    Array(j, at);
    out.reserve(j.size());
    Elements(j, at, [&](const V& obs, const Path& obs_at) {
      Array(obs, obs_at, 2);
      slam::Observation observation;
      int k = 0;
      obs.ForEachElement([&](const V& value) {
        if (k == 0) {
          observation.keyframe_id = Identifier(value, obs_at.Index(0));
        } else {
          observation.keypoint_index = static_cast<std::uint32_t>(
              Unsigned(value, obs_at.Index(1), std::numeric_limits<std::uint32_t>::max()));
        }
        ++k;
      });
      out.push_back(observation);
    });
    return out;
  }
  std::vector<Id> Ids(const V& j, const Path& at) const {
    std::vector<Id> out;
    if (!j.valid()) return out;
    Array(j, at);
    out.reserve(j.size());
    Elements(j, at, [&](const V& id, const Path& id_at) { out.push_back(Identifier(id, id_at)); });
    return out;
  }

  // Inserts value under id, failing on a duplicate; records the array index for messages.
  template <typename T>
  void Insert(std::map<Id, T>* container, std::map<Id, std::size_t>* locator, Id id, T value,
              const Path& at) const {
    // Files list entities in id order: the end hint makes that insertion O(1).
    const std::size_t before = container->size();
    container->emplace_hint(container->end(), id, std::move(value));
    if (container->size() == before) Fail(at.Key("id"), "duplicate id " + std::to_string(id));
    locator->emplace_hint(locator->end(), id, at.index);
  }

 private:
  const std::string& source_;
};

template <typename V>
slam::CameraParams DecodeCamera(const Decoder<V>& d, const V& element, const Path& at) {
  const typename V::Members j = element.MembersOf();
  slam::CameraParams c;
  if (const V name = d.OptionalField(j, "name"); name.valid()) c.name = d.String(name, at.Key("name"));
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
  if (const V distortion = d.OptionalField(j, "distortion"); distortion.valid()) {
    const Eigen::Matrix<double, 5, 1> k = d.template Vector<5>(distortion, at.Key("distortion"));
    for (int i = 0; i < 5; ++i) c.distortion[i] = k(i);
  }
  if (const V fps = d.OptionalField(j, "fps"); fps.valid()) c.fps = d.Number(fps, at.Key("fps"));
  return c;
}

template <typename V>
slam::Keyframe DecodeKeyframe(const Decoder<V>& d, const V& element, const Path& at) {
  const typename V::Members j = element.MembersOf();
  slam::Keyframe kf;
  kf.id = d.Identifier(d.Field(j, at, "id"), at.Key("id"));
  kf.camera_id = d.Identifier(d.Field(j, at, "camera_id"), at.Key("camera_id"));
  kf.timestamp = d.Number(d.Field(j, at, "timestamp"), at.Key("timestamp"));
  kf.cam_from_world = d.Pose(d.Field(j, at, "cam_from_world"), at.Key("cam_from_world"));
  if (const V keypoints = d.OptionalField(j, "keypoints"); keypoints.valid()) {
    d.Array(keypoints, at.Key("keypoints"));
    kf.keypoints.reserve(keypoints.size());
    d.Elements(keypoints, at.Key("keypoints"), [&](const V& element, const Path& kp_at) {
      const Eigen::Vector4d v = d.template Vector<4>(element, kp_at);
      slam::Keypoint kp;
      kp.x = static_cast<float>(v(0));
      kp.y = static_cast<float>(v(1));
      kp.angle_deg = static_cast<float>(v(2));
      if (v(3) != std::floor(v(3)) || v(3) < 0 || v(3) > 63) {
        d.Fail(kp_at.Index(3), "octave must be an integer in [0, 63]");
      }
      kp.octave = static_cast<int>(v(3));
      kf.keypoints.push_back(kp);
    });
  }
  if (const V descriptors = d.OptionalField(j, "descriptors"); descriptors.valid()) {
    d.Array(descriptors, at.Key("descriptors"));
    kf.descriptors.reserve(descriptors.size());
    d.Elements(descriptors, at.Key("descriptors"), [&](const V& element, const Path& d_at) {
      kf.descriptors.push_back(d.Descriptor(element, d_at));
    });
  }
  return kf;
}

template <typename V>
slam::PointLandmark DecodePoint(const Decoder<V>& d, const V& element, const Path& at) {
  const typename V::Members j = element.MembersOf();
  slam::PointLandmark p;
  p.id = d.Identifier(d.Field(j, at, "id"), at.Key("id"));
  p.position = d.template Vector<3>(d.Field(j, at, "position"), at.Key("position"));
  p.covariance = d.Matrix3(d.Field(j, at, "covariance"), at.Key("covariance"));
  if (const V desc = d.OptionalField(j, "descriptor"); desc.valid()) {
    p.descriptor = d.Descriptor(desc, at.Key("descriptor"));
  }
  p.observations = d.Observations(d.OptionalField(j, "observations"), at.Key("observations"));
  return p;
}

template <typename V>
slam::LineLandmark DecodeLine(const Decoder<V>& d, const V& element, const Path& at) {
  const typename V::Members j = element.MembersOf();
  slam::LineLandmark l;
  l.id = d.Identifier(d.Field(j, at, "id"), at.Key("id"));
  l.line.anchor = d.template Vector<3>(d.Field(j, at, "anchor"), at.Key("anchor"));
  l.line.direction = d.template Vector<3>(d.Field(j, at, "direction"), at.Key("direction"));
  l.information = d.Matrix3(d.Field(j, at, "information"), at.Key("information"));
  if (const V desc = d.OptionalField(j, "descriptor"); desc.valid()) {
    l.descriptor = d.Descriptor(desc, at.Key("descriptor"));
  }
  l.server_keyframe_ids =
      d.Ids(d.OptionalField(j, "server_keyframe_ids"), at.Key("server_keyframe_ids"));
  if (const V restored = d.OptionalField(j, "restored_point"); restored.valid()) {
    l.restored_point = d.template Vector<3>(restored, at.Key("restored_point"));
  }
  l.observations = d.Observations(d.OptionalField(j, "observations"), at.Key("observations"));
  return l;
}

template <typename V>
slam::ServerKeyframe DecodeServerKeyframe(const Decoder<V>& d, const V& element, const Path& at) {
  const typename V::Members j = element.MembersOf();
  slam::ServerKeyframe kf;
  kf.id = d.Identifier(d.Field(j, at, "id"), at.Key("id"));
  kf.camera_id = d.Identifier(d.Field(j, at, "camera_id"), at.Key("camera_id"));
  kf.timestamp = d.Number(d.Field(j, at, "timestamp"), at.Key("timestamp"));
  kf.cam_from_world = d.Pose(d.Field(j, at, "cam_from_world"), at.Key("cam_from_world"));
  kf.line_ids = d.Ids(d.OptionalField(j, "line_ids"), at.Key("line_ids"));
  return kf;
}

template <typename V, typename T, typename DecodeOne>
void DecodeSection(const Decoder<V>& d, const typename V::Members& root, const Path& root_at,
                   const char* name,
                   std::map<Id, T>* container, std::map<Id, std::size_t>* locator,
                   DecodeOne decode_one) {
  const V section = d.OptionalField(root, name);  // root: members
  if (!section.valid()) return;
  d.Elements(section, root_at.Key(name), [&](const V& element, const Path& element_at) {
    d.Object(element, element_at);
    T value = decode_one(d, element, element_at);
    // Cameras carry their id beside the parameters.
    Id id;
    if constexpr (std::is_same_v<T, slam::CameraParams>) {
      id = d.Identifier(d.Field(element.MembersOf(), element_at, "id"), element_at.Key("id"));
    } else {
      id = value.id;
    }
    d.Insert(container, locator, id, std::move(value), element_at);
  });
}

// The document's content (magic and version checked first), validated.
template <typename V>
slam::Map DecodeMap(const V& document, const std::string& source_name) {
  const Decoder<V> d(source_name);
  const Path root_at;
  if (!document.is_object()) d.Fail(root_at, "expected an object");
  const typename V::Members root = document.MembersOf();
  // Magic and version before anything else: a different file or a newer schema is named as such
  // instead of failing on some field.
  const V magic = d.OptionalField(root, "magic");
  if (!magic.valid() || !magic.is_string() || magic.bytes() != kMapMagic) {
    throw InputError(source_name, "not an lcv map file (no \"magic\": \"lcvmap\")");
  }
  const V version = d.Field(root, root_at, "schema_version");
  if (!version.is_number_integer() || version.as_integer() != mapping::kMapSchemaVersion) {
    d.Fail(root_at.Key("schema_version"), "schema version " + Decoder<V>::Describe(version) +
                                              " is not supported (this build reads " +
                                              std::to_string(mapping::kMapSchemaVersion) + ")");
  }

  slam::Map map;
  EntityLocator locator;
  if (const V description = d.OptionalField(root, "description"); description.valid()) {
    map.description = d.String(description, root_at.Key("description"));
  }
  DecodeSection(d, root, root_at, "cameras", &map.cameras, &locator.cameras, DecodeCamera<V>);
  DecodeSection(d, root, root_at, "keyframes", &map.keyframes, &locator.keyframes,
                DecodeKeyframe<V>);
  DecodeSection(d, root, root_at, "points", &map.points, &locator.points, DecodePoint<V>);
  DecodeSection(d, root, root_at, "lines", &map.lines, &locator.lines, DecodeLine<V>);
  DecodeSection(d, root, root_at, "server_keyframes", &map.server_keyframes,
                &locator.server_keyframes, DecodeServerKeyframe<V>);
  if (const V edges = d.OptionalField(root, "loop_edges"); edges.valid()) {
    d.Elements(edges, root_at.Key("loop_edges"), [&](const V& edge, const Path& at) {
      d.Array(edge, at, 2);
      Id ids[2] = {slam::kInvalidId, slam::kInvalidId};
      int i = 0;
      edge.ForEachElement([&](const V& value) {
        ids[i] = d.Identifier(value, at.Index(i));
        ++i;
      });
      map.loop_edges.emplace_back(ids[0], ids[1]);
    });
  }

  ValidateMapAt(map, source_name, locator);
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

// Strips nlohmann's "[json.exception.parse_error.101] " tag from a message.
std::string WithoutTag(const std::string& what) {
  const std::size_t tag_end = what.find("] ");
  return tag_end == std::string::npos ? what : what.substr(tag_end + 2);
}

}  // namespace

slam::Map ParseJsonMap(const std::string& bytes, const std::string& source) {
  json root;
  try {
    CheckJsonNesting(bytes, source);
    root = json::parse(bytes);
  } catch (const json::exception& e) {
    throw InputError(source, "invalid JSON: " + WithoutTag(e.what()));
  }
  try {
    return DecodeMap(JsonValue(&root), source);
  } catch (const json::exception& e) {
    // Defence in depth: the decoder checks types before every access, so this is not expected.
    throw InputError(source, std::string("malformed map: ") + e.what());
  }
}

slam::Map ParseMessagePackMap(const std::string& bytes, const std::string& source) {
  // After the structure scan every length fits the buffer: the views never read past it.
  CheckMessagePackStructure(bytes, source);
  try {
    return DecodeMap(MsgpackValue(reinterpret_cast<const unsigned char*>(bytes.data())),
                     source);
  } catch (const MsgpackFormatError& e) {
    throw InputError(source, std::string("invalid MessagePack: ") + e.what());
  }
}

}  // namespace lcv::mapping::internal
