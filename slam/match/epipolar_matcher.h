#pragma once
// Search for new-point triangulation between two keyframes (ORB-SLAM's SearchForTriangulation),
// on bearings so that every camera model works: keypoints that hold no landmark in either
// keyframe are paired when their descriptors are close (Hamming <= max_hamming_distance, ratio
// test), their bearings satisfy the epipolar constraint
//   |f2 . (E f1)| / |E f1| <= sin(angle threshold),   E = [t_21]x R_21,
// with the angle threshold scaled by the keypoint octave, and the orientation histogram agrees.
// Each keypoint is used at most once.

#include <utility>
#include <vector>

#include "slam/data/slam_map.h"

namespace lcv::slam {

struct EpipolarMatchOptions {
  int max_hamming_distance = 50;
  float ratio = 0.6f;
  // Epipolar angle tolerance in units of the keypoint's pixel scale: tolerance =
  // sigma_factor * Scale(octave2) * radians_per_pixel.
  double sigma_factor = 2.0;
  double radians_per_pixel = 1.0 / 500.0;  // set from the camera (RadiansPerPixel)
  bool check_orientation = true;
  int orientation_bins = 30;
  // Bearings nearer than this angle (rad) to the epipole of the other view are skipped: they
  // carry no depth information.
  double min_angle_to_epipole_rad = 0.02;
};

// Pairs (keypoint index in kf1, keypoint index in kf2). Returns their count.
int MatchForTriangulation(const SlamKeyframe& kf1, const SlamKeyframe& kf2,
                          const EpipolarMatchOptions& options,
                          std::vector<std::pair<int, int>>* matches);

// The angle one pixel spans near the image centre of a camera (radians): converts pixel
// thresholds to bearing-angle thresholds.
double RadiansPerPixel(const Camera& camera);

}  // namespace lcv::slam
