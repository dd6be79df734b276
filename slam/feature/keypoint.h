#pragma once
// Plain keypoint and ORB descriptor types shared by the feature extractor, the map model and the
// map files. No OpenCV here: data/ and mapping/io use them without OpenCV headers.

#include <array>
#include <cstdint>

namespace lcv::slam {

// 256-bit binary ORB descriptor.
using OrbDescriptor = std::array<std::uint8_t, 32>;

struct Keypoint {
  float x = 0.f;  // px in the raw (distorted) image, where it was detected
  float y = 0.f;
  float angle_deg = -1.f;  // orientation, degrees in [0, 360); -1 when unknown
  int octave = 0;          // pyramid level it was detected at
};

// Hamming distance between two descriptors (0..256).
int HammingDistance(const OrbDescriptor& a, const OrbDescriptor& b);

}  // namespace lcv::slam
