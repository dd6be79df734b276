#pragma once
// The map file reader's decoding step (map_file.h's ParseMap after the encoding is detected),
// internal to mapping/io.

#include <string>

#include "slam/data/map.h"

namespace lcv::mapping::internal {

inline constexpr const char kMapMagic[] = "lcvmap";

// A JSON text / MessagePack buffer (first byte opens a map) -> validated map. Throws
// lcv::InputError("<source_name>: <pointer>: <problem>") as ParseMap documents.
slam::Map ParseJsonMap(const std::string& bytes, const std::string& source_name);
slam::Map ParseMessagePackMap(const std::string& bytes, const std::string& source_name);

}  // namespace lcv::mapping::internal
