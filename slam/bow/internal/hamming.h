#pragma once
// The vocabulary's name for the Hamming distance (HammingDistance, inline in
// slam/feature/keypoint.h; the tree descent does K of them per level per feature).

#include <cstdint>
#include <cstring>

#include "slam/feature/keypoint.h"

namespace lcv::slam::internal {

inline int Hamming256(const OrbDescriptor& a, const OrbDescriptor& b) {
  return HammingDistance(a, b);
}

}  // namespace lcv::slam::internal
