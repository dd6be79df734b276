#pragma once
// Inlined Hamming distance for the vocabulary's hot loops (slam/feature's HammingDistance is an
// out-of-line call; the tree descent does K of them per level per feature).

#include <cstdint>
#include <cstring>

#include "slam/feature/keypoint.h"

namespace lcv::slam::internal {

inline int Hamming256(const OrbDescriptor& a, const OrbDescriptor& b) {
  int distance = 0;
  for (int i = 0; i < 32; i += 8) {
    std::uint64_t wa, wb;
    std::memcpy(&wa, a.data() + i, 8);
    std::memcpy(&wb, b.data() + i, 8);
    distance += __builtin_popcountll(wa ^ wb);
  }
  return distance;
}

}  // namespace lcv::slam::internal
