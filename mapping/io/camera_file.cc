#include "mapping/io/camera_file.h"

#include <charconv>
#include <cmath>
#include <optional>
#include <sstream>

#include <nlohmann/json.hpp>

#include "mapping/io/atomic_file.h"
#include "mapping/io/yaml_subset.h"
#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

using nlohmann::json;

// The camera fields of a settings tree and how to name them in messages.
struct Section {
  json fields = json::object();
  std::string prefix;  // "Camera." or "" (top level)
};

Section FindCameraSection(const json& root, const std::string& source) {
  if (!root.is_object()) throw InputError(source, "expected a mapping of camera fields at top level");
  for (const char* name : {"Camera", "camera"}) {
    const auto it = root.find(name);
    if (it != root.end()) {
      if (!it->is_object()) {
        throw InputError(source, std::string(name) + ": expected a mapping of camera fields");
      }
      return Section{*it, std::string(name) + "."};
    }
  }
  // stella_vslam 0.2 / ORB-SLAM flat keys: "Camera.fx: 718.856".
  Section flat{json::object(), "Camera."};
  for (const auto& [key, value] : root.items()) {
    if (key.rfind("Camera.", 0) == 0) flat.fields[key.substr(7)] = value;
  }
  if (!flat.fields.empty()) return flat;
  return Section{root, ""};
}

class FieldReader {
 public:
  FieldReader(const Section& section, const std::string& source)
      : section_(section), source_(source) {}

  std::string Name(const std::string& key) const { return section_.prefix + key; }

  [[noreturn]] void Fail(const std::string& key, const std::string& what) const {
    throw InputError(source_, Name(key) + ": " + what);
  }

  const json* Find(const std::string& key) const {
    const auto it = section_.fields.find(key);
    if (it == section_.fields.end() || it->is_null()) return nullptr;
    return &*it;
  }

  std::optional<double> Number(const std::string& key) const {
    const json* v = Find(key);
    if (!v) return std::nullopt;
    if (!v->is_number()) Fail(key, "expected a number, got " + v->dump(-1, ' ', false, json::error_handler_t::replace));
    const double d = v->get<double>();
    if (!std::isfinite(d)) Fail(key, "expected a finite number, got " + v->dump(-1, ' ', false, json::error_handler_t::replace));
    return d;
  }

  double RequiredNumber(const std::string& key) const {
    const auto d = Number(key);
    if (!d) Fail(key, "missing");
    return *d;
  }

  std::optional<int> Integer(const std::string& key) const {
    const auto d = Number(key);
    if (!d) return std::nullopt;
    if (*d != std::floor(*d) || std::fabs(*d) > 1e9) {
      Fail(key, "expected an integer, got " + Find(key)->dump(-1, ' ', false, json::error_handler_t::replace));
    }
    return static_cast<int>(*d);
  }

  std::optional<std::string> String(const std::string& key) const {
    const json* v = Find(key);
    if (!v) return std::nullopt;
    if (!v->is_string()) Fail(key, "expected a string, got " + v->dump(-1, ' ', false, json::error_handler_t::replace));
    return v->get<std::string>();
  }

 private:
  const Section& section_;
  const std::string& source_;
};

slam::CameraModel ReadModel(const FieldReader& fields) {
  if (const auto model = fields.String("model")) {
    const auto parsed = slam::ParseCameraModel(*model);
    if (!parsed) {
      fields.Fail("model", "unknown camera model \"" + *model +
                               "\" (expected perspective, fisheye or equirectangular)");
    }
    return *parsed;
  }
  // ORB-SLAM spelling.
  if (const auto type = fields.String("type")) {
    if (*type == "PinHole" || *type == "Pinhole" || *type == "pinhole") {
      return slam::CameraModel::kPerspective;
    }
    if (*type == "KannalaBrandt8" || *type == "KannalaBrandt") return slam::CameraModel::kFisheye;
    fields.Fail("type", "unknown camera type \"" + *type + "\" (expected PinHole or KannalaBrandt8)");
  }
  fields.Fail("model", "missing (expected perspective, fisheye or equirectangular)");
}

// Image size from cols/rows or width/height.
std::optional<int> ReadSize(const FieldReader& fields, const char* key, const char* alias) {
  const auto a = fields.Integer(key);
  const auto b = fields.Integer(alias);
  if (a && b && *a != *b) {
    fields.Fail(key, "is " + std::to_string(*a) + " but " + fields.Name(alias) + " is " +
                         std::to_string(*b));
  }
  return a ? a : b;
}

}  // namespace

void CheckCameraParams(const slam::CameraParams& params, const std::string& source_name) {
  if (const auto problem = params.Problem()) throw InputError(source_name, "Camera: " + *problem);
}

slam::CameraParams ParseCameraFile(const std::string& bytes, const std::string& source_name,
                                   const CameraFileOptions& options) {
  json root;
  const size_t first = bytes.find_first_not_of(" \t\r\n");
  if (first != std::string::npos && bytes[first] == '{') {
    try {
      root = json::parse(bytes, nullptr, /*allow_exceptions=*/true, /*ignore_comments=*/true);
    } catch (const json::exception& e) {
      throw InputError(source_name, std::string("invalid JSON: ") + e.what());
    }
  } else {
    root = ParseYamlSubset(bytes, source_name);
  }
  if (root.is_null()) throw InputError(source_name, "empty camera file");
  const Section section = FindCameraSection(root, source_name);
  const FieldReader fields(section, source_name);

  slam::CameraParams params;
  if (const auto name = fields.String("name")) params.name = *name;
  params.model = ReadModel(fields);
  if (params.model != slam::CameraModel::kEquirectangular) {
    params.fx = fields.RequiredNumber("fx");
    params.fy = fields.RequiredNumber("fy");
    params.cx = fields.RequiredNumber("cx");
    params.cy = fields.RequiredNumber("cy");
  }
  params.distortion.fill(0.0);
  if (params.model == slam::CameraModel::kPerspective) {
    const char* keys[5] = {"k1", "k2", "p1", "p2", "k3"};
    for (int i = 0; i < 5; ++i) params.distortion[i] = fields.Number(keys[i]).value_or(0.0);
  } else if (params.model == slam::CameraModel::kFisheye) {
    const char* keys[4] = {"k1", "k2", "k3", "k4"};
    for (int i = 0; i < 4; ++i) params.distortion[i] = fields.Number(keys[i]).value_or(0.0);
    for (const char* key : {"p1", "p2"}) {
      const auto v = fields.Number(key);
      if (v && *v != 0.0) fields.Fail(key, "a fisheye camera has no tangential distortion");
    }
  }
  const auto cols = ReadSize(fields, "cols", "width");
  const auto rows = ReadSize(fields, "rows", "height");
  if (options.require_image_size) {
    if (!cols) fields.Fail("cols", "missing (image width in pixels)");
    if (!rows) fields.Fail("rows", "missing (image height in pixels)");
  }
  params.cols = cols.value_or(0);
  params.rows = rows.value_or(0);
  if (const auto fps = fields.Number("fps")) {
    if (*fps <= 0) fields.Fail("fps", "must be > 0, got " + FormatDoubleExact(*fps));
    params.fps = *fps;
  }
  if (options.require_image_size || (cols && rows)) CheckCameraParams(params, source_name);
  return params;
}

slam::CameraParams ReadCameraFile(const std::string& path, const CameraFileOptions& options) {
  return ParseCameraFile(ReadTextFile(path, std::size_t{16} << 20), path, options);
}

std::string FormatDoubleExact(double value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

std::string SerializeCameraFile(const slam::CameraParams& params) {
  std::ostringstream out;
  // Quote the name as a JSON string (a valid double-quoted YAML scalar).
  out << "# LC-VSLAM camera file (stella_vslam field names; see mapping/io/camera_file.h)\n"
      << "Camera:\n"
      << "  name: " << json(params.name).dump(-1, ' ', false, json::error_handler_t::replace) << "\n"
      << "  model: \"" << slam::CameraModelName(params.model) << "\"\n";
  if (params.model != slam::CameraModel::kEquirectangular) {
    out << "  fx: " << FormatDoubleExact(params.fx) << "\n"
        << "  fy: " << FormatDoubleExact(params.fy) << "\n"
        << "  cx: " << FormatDoubleExact(params.cx) << "\n"
        << "  cy: " << FormatDoubleExact(params.cy) << "\n";
  }
  if (params.model == slam::CameraModel::kPerspective) {
    const char* keys[5] = {"k1", "k2", "p1", "p2", "k3"};
    for (int i = 0; i < 5; ++i) {
      out << "  " << keys[i] << ": " << FormatDoubleExact(params.distortion[i]) << "\n";
    }
  } else if (params.model == slam::CameraModel::kFisheye) {
    const char* keys[4] = {"k1", "k2", "k3", "k4"};
    for (int i = 0; i < 4; ++i) {
      out << "  " << keys[i] << ": " << FormatDoubleExact(params.distortion[i]) << "\n";
    }
  }
  out << "  cols: " << params.cols << "\n"
      << "  rows: " << params.rows << "\n"
      << "  fps: " << FormatDoubleExact(params.fps) << "\n";
  return out.str();
}

void WriteCameraFile(const slam::CameraParams& params, const std::string& path) {
  WriteFileAtomically(path, SerializeCameraFile(params));
}

}  // namespace lcv::mapping
