#pragma once
// Internals of the map file reader (mapping/io/map_file.h), exposed for its tests.

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>

#include "slam/data/map.h"

namespace lcv::mapping::internal {

// Deepest nesting of arrays/objects a map file needs is 4 (/keyframes/3/keypoints/7); anything
// much deeper is a corrupt or hostile file, refused before the recursive decoder sees it.
inline constexpr int kMaxMapNesting = 32;

// Walks the MessagePack structure without building it: checks every type byte, that every
// declared length fits the remaining bytes, that exactly one value fills the buffer and that
// nesting stays <= kMaxMapNesting. Throws lcv::InputError("<source>: ...") otherwise.
void CheckMessagePackStructure(const std::string& bytes, const std::string& source_name);

// The same nesting limit for JSON text (brackets outside strings).
void CheckJsonNesting(const std::string& bytes, const std::string& source_name);

// Where each entity sits in its file array, for error messages ("/lines/17"). Entities missing
// from the table are located by their ordinal in id order, which is where WriteMap puts them.
struct EntityLocator {
  std::map<slam::Id, std::size_t> keyframes, points, lines, server_keyframes, cameras;
};

// ValidateMap with file positions.
void ValidateMapAt(const slam::Map& map, const std::string& source_name,
                   const EntityLocator& locator);

// Hex form of a descriptor (64 lowercase digits) and back; false for anything else.
std::string DescriptorToHex(const slam::OrbDescriptor& descriptor);
bool DescriptorFromHex(const std::string& hex, slam::OrbDescriptor* descriptor);

}  // namespace lcv::mapping::internal
