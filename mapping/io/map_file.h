#pragma once
// Map files: one versioned schema, two encodings, both through nlohmann-json:
//   .json  - readable JSON;
//   .lcmap - MessagePack (compact).
// The reader detects the encoding from the content, not the name, checks the magic ("lcvmap")
// and the schema version first, then validates everything (ids exist, unit directions, finite
// numbers, symmetric PSD information matrices) and rejects a bad file with lcv::InputError
// naming the file and the JSON pointer of the problem ("a.lcmap: /lines/17/direction: norm 0").
// It never crashes on any input. See docs/map-format.md for the schema.

#include <string>

#include "slam/data/map.h"

namespace lcv::mapping {

enum class MapEncoding { kJson, kMessagePack };

inline constexpr int kMapSchemaVersion = 1;

// Encoding chosen from the file name: ".json" -> JSON, anything else -> MessagePack.
MapEncoding EncodingForPath(const std::string& path);

// Reads and validates a map. Throws lcv::InputError.
slam::Map ReadMap(const std::string& path);
// The bytes of a map file, read only after its first bytes look like a map (a JSON object or a
// MessagePack map): /dev/zero or a 3 GB file of zeros is refused at once. Throws lcv::InputError.
std::string ReadMapBytes(const std::string& path);
// Same from bytes; source_name is used in error messages.
slam::Map ParseMap(const std::string& bytes, const std::string& source_name);

// Writes atomically (temporary file + rename). Throws lcv::InputError on I/O failure, and
// (writing nothing) when the map fails ValidateMap: every map written reads back.
void WriteMap(const slam::Map& map, const std::string& path);
void WriteMap(const slam::Map& map, const std::string& path, MapEncoding encoding);
std::string SerializeMap(const slam::Map& map, MapEncoding encoding);

// The reader's semantic checks on an in-memory map (also for maps built by importers).
// Throws lcv::InputError("<source_name>: <pointer>: <problem>").
void ValidateMap(const slam::Map& map, const std::string& source_name);

}  // namespace lcv::mapping
