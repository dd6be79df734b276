#include "privacy/concealed_regions.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <nlohmann/json.hpp>

#include "mapping/io/atomic_file.h"
#include "slam/util/error.h"

namespace lcv::privacy {
namespace {

using nlohmann::json;

json ParseJson(const std::string& text, const std::string& source) {
  try {
    return json::parse(text);
  } catch (const json::parse_error& e) {
    throw InputError(source, std::string("not valid JSON: ") + e.what());
  }
}

Eigen::Vector3d ReadVec3(const json& j, const std::string& source, const std::string& pointer) {
  if (!j.is_array() || j.size() != 3) {
    throw InputError(source, pointer + ": expected an array of 3 numbers");
  }
  Eigen::Vector3d v;
  for (int a = 0; a < 3; ++a) {
    if (!j[a].is_number() || !std::isfinite(j[a].get<double>())) {
      throw InputError(source, pointer + "/" + std::to_string(a) + ": expected a finite number");
    }
    v[a] = j[a].get<double>();
  }
  return v;
}

Eigen::AlignedBox3d ReadBox(const json& j, const std::string& source, const std::string& pointer) {
  if (!j.is_object() || !j.contains("min") || !j.contains("max")) {
    throw InputError(source, pointer + ": expected an object with \"min\" and \"max\"");
  }
  const Eigen::Vector3d lo = ReadVec3(j["min"], source, pointer + "/min");
  const Eigen::Vector3d hi = ReadVec3(j["max"], source, pointer + "/max");
  if ((hi.array() < lo.array()).any()) {
    throw InputError(source, pointer + ": \"max\" is below \"min\" on some axis");
  }
  return Eigen::AlignedBox3d(lo, hi);
}

std::string ReadName(const json& j, const std::string& source, const std::string& pointer,
                     std::size_t index) {
  if (!j.contains("name")) return "region_" + std::to_string(index);
  if (!j["name"].is_string()) throw InputError(source, pointer + "/name: expected a string");
  return j["name"].get<std::string>();
}

}  // namespace

ConcealedSpec ParseConcealedRegions(const std::string& text, const std::string& source) {
  const json root = ParseJson(text, source);
  if (!root.is_object()) throw InputError(source, "expected a JSON object");
  if (!root.contains("regions") && !root.contains("line_ids")) {
    throw InputError(source, "expected \"regions\" and/or \"line_ids\"");
  }
  ConcealedSpec spec;
  if (root.contains("regions")) {
    const json& regions = root["regions"];
    if (!regions.is_array()) throw InputError(source, "/regions: expected an array");
    for (std::size_t i = 0; i < regions.size(); ++i) {
      const std::string pointer = "/regions/" + std::to_string(i);
      if (!regions[i].is_object()) throw InputError(source, pointer + ": expected an object");
      ConcealedRegion region;
      region.name = ReadName(regions[i], source, pointer, i);
      region.box = ReadBox(regions[i], source, pointer);
      spec.regions.push_back(region);
    }
  }
  if (root.contains("line_ids")) {
    const json& ids = root["line_ids"];
    if (!ids.is_array()) throw InputError(source, "/line_ids: expected an array");
    for (std::size_t i = 0; i < ids.size(); ++i) {
      if (!ids[i].is_number_unsigned()) {
        throw InputError(source, "/line_ids/" + std::to_string(i) +
                                     ": expected a non-negative integer id");
      }
      spec.line_ids.push_back(ids[i].get<slam::Id>());
    }
  }
  return spec;
}

// A face of the region's box rests on a visible object when that object's box ends where the
// face is and overlaps the face with positive area (a desk under a document), or when the face
// lies on a face of a visible box around it (the floor or a wall of a room: lcv synth's room is
// a box whose inside is seen). kContactTolerance: scene units (metres for lcv synth), rounding of
// hand-written files.
static void MarkRestingFaces(const std::vector<Eigen::AlignedBox3d>& visible,
                             ConcealedRegion* region) {
  constexpr double kContactTolerance = 1e-4;
  const Eigen::AlignedBox3d& box = region->box;
  for (const Eigen::AlignedBox3d& other : visible) {
    if (other.isApprox(box)) continue;  // the object itself (seen by the client)
    for (int axis = 0; axis < 3; ++axis) {
      bool overlaps = true;
      for (int k = 1; k < 3; ++k) {
        const int a = (axis + k) % 3;
        overlaps = overlaps && std::min(box.max()[a], other.max()[a]) >
                                   std::max(box.min()[a], other.min()[a]);
      }
      if (!overlaps) continue;
      if (std::abs(other.max()[axis] - box.min()[axis]) <= kContactTolerance ||
          std::abs(other.min()[axis] - box.min()[axis]) <= kContactTolerance) {
        region->rests_min[axis] = true;
      }
      if (std::abs(other.min()[axis] - box.max()[axis]) <= kContactTolerance ||
          std::abs(other.max()[axis] - box.max()[axis]) <= kContactTolerance) {
        region->rests_max[axis] = true;
      }
    }
  }
}

ConcealedSpec ParseSceneConcealedRegions(const std::string& text, const std::string& source) {
  const json root = ParseJson(text, source);
  if (!root.is_object() || !root.contains("objects") || !root["objects"].is_array()) {
    throw InputError(source, "/objects: expected an array of scene objects");
  }
  ConcealedSpec spec;
  const json& objects = root["objects"];
  std::vector<Eigen::AlignedBox3d> seen_by_client;  // boxes of objects in the client sequence
  for (std::size_t i = 0; i < objects.size(); ++i) {
    const std::string pointer = "/objects/" + std::to_string(i);
    const json& o = objects[i];
    if (!o.is_object()) throw InputError(source, pointer + ": expected an object");
    // lcv synth marks the sequences an object appears in; one missing from either sequence was
    // concealed there.
    bool concealed = false;
    for (const char* flag : {"in_map", "in_client"}) {
      if (!o.contains(flag)) continue;
      if (!o[flag].is_boolean()) {
        throw InputError(source, pointer + "/" + flag + ": expected true or false");
      }
      concealed |= !o[flag].get<bool>();
    }
    const bool in_client = !o.contains("in_client") || o["in_client"].get<bool>();
    if (!concealed && !in_client) continue;
    if (!o.contains("bbox_min") || !o.contains("bbox_max")) {
      if (!concealed) continue;  // a visible object without a box supports nothing we know of
      throw InputError(source, pointer + ": a concealed object needs \"bbox_min\" and \"bbox_max\"");
    }
    const Eigen::AlignedBox3d box =
        ReadBox(json{{"min", o["bbox_min"]}, {"max", o["bbox_max"]}}, source, pointer + "/bbox");
    if (in_client) seen_by_client.push_back(box);
    if (!concealed) continue;
    ConcealedRegion region;
    region.name = ReadName(o, source, pointer, i);
    region.box = box;
    spec.regions.push_back(region);
  }
  for (ConcealedRegion& region : spec.regions) MarkRestingFaces(seen_by_client, &region);
  return spec;
}

ConcealedSpec ReadConcealedRegions(const std::string& path) {
  return ParseConcealedRegions(mapping::ReadTextFile(path), path);
}

ConcealedSpec ReadSceneConcealedRegions(const std::string& path) {
  return ParseSceneConcealedRegions(mapping::ReadTextFile(path), path);
}

}  // namespace lcv::privacy
