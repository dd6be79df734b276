#include "slam/data/map.h"

#include <algorithm>

namespace lcv::slam {
namespace {

template <typename Container>
Id LargestKey(const Container& c) {
  return c.empty() ? 0 : c.rbegin()->first;
}

}  // namespace

Id Map::NextFreeId() const {
  const bool empty = cameras.empty() && keyframes.empty() && points.empty() && lines.empty() &&
                     server_keyframes.empty();
  if (empty) return 1;
  return std::max({LargestKey(cameras), LargestKey(keyframes), LargestKey(points),
                   LargestKey(lines), LargestKey(server_keyframes)}) + 1;
}

bool IsPublishedLineCloud(const Map& map) {
  if (!map.keyframes.empty() || !map.points.empty()) return false;
  for (const auto& [id, line] : map.lines) {
    if (line.restored_point || !line.observations.empty()) return false;
  }
  return true;
}

}  // namespace lcv::slam
