#include "slam/feature/keypoint.h"

#include <cstring>

namespace lcv::slam {

int HammingDistance(const OrbDescriptor& a, const OrbDescriptor& b) {
  int distance = 0;
  for (int i = 0; i < 32; i += 8) {
    std::uint64_t wa, wb;
    std::memcpy(&wa, a.data() + i, 8);
    std::memcpy(&wb, b.data() + i, 8);
    distance += __builtin_popcountll(wa ^ wb);
  }
  return distance;
}

}  // namespace lcv::slam
