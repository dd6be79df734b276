#pragma once
// Synthetic ORB descriptors for the BoW tests: random prototypes and noisy copies of them.

#include <algorithm>
#include <random>
#include <vector>

#include "slam/feature/keypoint.h"

namespace lcv::slam::test {

inline OrbDescriptor RandomDescriptor(std::mt19937_64& rng) {
  OrbDescriptor d;
  std::uniform_int_distribution<int> byte(0, 255);
  for (auto& b : d) b = static_cast<std::uint8_t>(byte(rng));
  return d;
}

// A copy of d with exactly num_flips distinct bits flipped.
inline OrbDescriptor FlipBits(const OrbDescriptor& d, int num_flips, std::mt19937_64& rng) {
  std::vector<int> bits(256);
  for (int i = 0; i < 256; ++i) bits[i] = i;
  std::shuffle(bits.begin(), bits.end(), rng);
  OrbDescriptor out = d;
  for (int i = 0; i < num_flips; ++i) out[bits[i] / 8] ^= static_cast<std::uint8_t>(1u << (bits[i] % 8));
  return out;
}

}  // namespace lcv::slam::test
