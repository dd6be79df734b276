#pragma once
// Plain keypoint and ORB descriptor types shared by the feature extractor, the map model and the
// map files. No OpenCV here: data/ and mapping/io use them without OpenCV headers.

#include <array>
#include <cstdint>
#include <cstring>
#include <limits>

namespace lcv::slam {

// 256-bit binary ORB descriptor.
using OrbDescriptor = std::array<std::uint8_t, 32>;

struct Keypoint {
  float x = 0.f;  // px in the raw (distorted) image, where it was detected
  float y = 0.f;
  float angle_deg = -1.f;  // orientation, degrees in [0, 360); -1 when unknown
  int octave = 0;          // pyramid level it was detected at
};

// Bits set in a 64-bit word, without the POPCNT instruction: the build targets baseline x86-64
// (no -march, see CMakeLists.txt), where __builtin_popcountll is a call into libgcc's table
// version (5% of an equirectangular client run under perf). The SWAR sum is ~12 inline
// instructions.
inline int PopCount64(std::uint64_t x) {
  x = x - ((x >> 1) & 0x5555555555555555ULL);
  x = (x & 0x3333333333333333ULL) + ((x >> 2) & 0x3333333333333333ULL);
  x = (x + (x >> 4)) & 0x0f0f0f0f0f0f0f0fULL;
  return static_cast<int>((x * 0x0101010101010101ULL) >> 56);
}

// Hamming distance between two descriptors (0..256).
inline int HammingDistance(const OrbDescriptor& a, const OrbDescriptor& b) {
  int distance = 0;
  for (int i = 0; i < 32; i += 8) {
    std::uint64_t wa, wb;
    std::memcpy(&wa, a.data() + i, 8);
    std::memcpy(&wb, b.data() + i, 8);
    distance += PopCount64(wa ^ wb);
  }
  return distance;
}

// The two smallest distances offered and the candidate of the smallest: the bookkeeping of the
// nearest-neighbour search with Lowe's ratio test that every descriptor matcher does (ORB-SLAM:
// best and second-best distance). Ties keep the first candidate; a distance equal to the best
// becomes the second.
struct NearestTwo {
  static constexpr int kNone = std::numeric_limits<int>::max();
  int best = kNone;
  int second = kNone;
  int index = -1;  // candidate of `best`, -1 before any offer

  void Offer(int distance, int candidate) {
    if (distance < best) {
      second = best;
      best = distance;
      index = candidate;
    } else if (distance < second) {
      second = distance;
    }
  }
};

}  // namespace lcv::slam
