#pragma once
// Images of any camera model resampled from a cube map, so that synthetic fisheye and
// equirectangular frames go through the project's own camera models (slam/camera) and ground
// truth and projection agree to sub-pixel level.
//
// The cube is centred on the camera and aligned with its frame (x right, y down, z forward).
// Face k is an ideal pinhole image of size face_size + 2 * border square pixels with focal
// length face_size / 2 and principal point at the image centre, looking along CubeFaceDirection;
// the central face_size pixels span exactly 90 degrees and the border lets bilinear lookups near
// a face edge stay inside the face. The faces are stacked vertically in one "atlas" image (face k
// in rows [k * S, (k + 1) * S), S = face_size + 2 * border), so one cv::remap resamples a frame.
//
// For each output pixel: bearing = camera.Unproject(pixel) -> face with the largest |component|
// -> face pixel -> bilinear lookup. Pixels the model cannot unproject are black.

#include <array>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "slam/camera/camera.h"

namespace lcv::render {

inline constexpr int kNumCubeFaces = 6;

// face_from_cam rotation of face k: 0 +z (front), 1 +x (right), 2 -z (back), 3 -x (left),
// 4 -y (up), 5 +y (down). Each face image has its own x right, y down, z along the face.
Eigen::Matrix3d CubeFaceFromCam(int face);

// Face size (pixels across the central 90 degrees) that samples the cube at least as finely as
// the camera samples the sphere anywhere in its image, times oversampling. Even, >= 16.
int CubeFaceSizeFor(const slam::Camera& camera, double oversampling = 1.0);

class CubeMapResampler {
 public:
  // Precomputes the lookup table for camera (O(cols * rows) unprojections, done once).
  // supersampling k > 1: the table samples k x k points per output pixel (at sub-pixel
  // offsets (i + 0.5) / k - 0.5) and Resample averages them (INTER_AREA), like a sensor pixel
  // integrating its footprint.
  CubeMapResampler(const slam::Camera& camera, int face_size, int border = 2,
                   int supersampling = 1);

  int face_size() const { return face_size_; }
  int border() const { return border_; }
  int face_image_size() const { return face_size_ + 2 * border_; }
  double face_focal_px() const { return 0.5 * face_size_; }
  double face_principal_px() const { return 0.5 * (face_image_size() - 1); }
  // Faces that at least one output pixel looks up (others need not be rendered).
  const std::array<bool, kNumCubeFaces>& used_faces() const { return used_faces_; }

  // The output image (size of the camera, type of the atlas) from an atlas of
  // kNumCubeFaces * face_image_size() rows and face_image_size() columns.
  cv::Mat Resample(const cv::Mat& atlas) const;

 private:
  int face_size_ = 0;
  int border_ = 0;
  int supersampling_ = 1;
  int cols_ = 0, rows_ = 0;
  std::array<bool, kNumCubeFaces> used_faces_{};
  cv::Mat map_fixed_;   // CV_16SC2, cv::convertMaps of the float maps (fast remap)
  cv::Mat map_interp_;  // CV_16UC1 interpolation table
};

}  // namespace lcv::render
