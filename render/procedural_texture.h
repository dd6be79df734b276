#pragma once
// Procedural textures rich in corners (for ORB) and checker markers at known texels (for ground
// truth), drawn deterministically from a seed with OpenCV's drawing functions.
//
// No photographs: the generator must work on a fresh machine with only the build dependencies,
// and photographs would need per-file licence checks. Instead every texture mixes structures at
// several scales (windows, signs, glyph strings, bricks, blobs, fine grain), so that ORB finds
// well-spread, distinctive corners at every pyramid level and no two surfaces look alike.

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

namespace lcv::render {

// A small deterministic generator (SplitMix64): the same seed gives the same sequence on every
// platform, unlike std::uniform_*_distribution.
class SplitMix64 {
 public:
  explicit SplitMix64(std::uint64_t seed) : state_(seed) {}
  std::uint64_t Next() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  // Uniform in [0, 1).
  double Uniform() { return static_cast<double>(Next() >> 11) * 0x1.0p-53; }
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  // Uniform integer in [lo, hi].
  int UniformInt(int lo, int hi) {
    return lo + static_cast<int>(Next() % static_cast<std::uint64_t>(hi - lo + 1));
  }

 private:
  std::uint64_t state_;
};

enum class TextureStyle {
  kFacade,   // building front: storeys of windows, shop signs, bricks or panels
  kGround,   // asphalt or pavement: grain, lane marks, patches, manholes, painted text
  kWall,     // indoor wall: posters, frames, shelves
  kFloor,    // indoor floor: planks or tiles
  kWood,     // desk: grain plus papers, pens, sticky notes
  kObject,   // small objects (boxes, monitor, books): labels and print
  kPrivacy,  // the privacy object: a document with a photo, text and a signature
};

// A cols x rows CV_8UC3 BGR texture. Precondition: cols, rows >= 8.
cv::Mat MakeTexture(TextureStyle style, int cols, int rows, std::uint64_t seed);

// Draws a 2x2 checker marker whose centre corner lies on the texel boundary (col, row): squares of
// half_size texels, black top-left and bottom-right, white elsewhere, inside a white frame of
// half_size / 2 texels. Its centre is a sharp X-corner that cv::cornerSubPix finds precisely.
void DrawCheckerMarker(cv::Mat* texture, int col, int row, int half_size);

// Up to `count` marker centres on a grid of `half_size`-multiples, not overlapping each other
// and at least one marker size away from the border, drawn into texture; returns their texel
// coordinates (col, row). Fewer when the texture is too small.
std::vector<Eigen::Vector2i> PlaceCheckerMarkers(cv::Mat* texture, int count, int half_size,
                                                 SplitMix64* rng);

}  // namespace lcv::render
