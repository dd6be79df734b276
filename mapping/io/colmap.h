#pragma once
// Import of a COLMAP sparse model in text form (cameras.txt, images.txt, points3D.txt, as
// written by `colmap model_converter --output_type TXT`) as a client point map.
//
// Mapping to the map model (slam/data/map.h):
// - cameras: SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV, FULL_OPENCV (only with
//   k4 = k5 = k6 = 0) -> perspective with {k1, k2, p1, p2, k3}; OPENCV_FISHEYE -> fisheye
//   {k1, k2, k3, k4}. Other models are rejected, naming the model and the line. COLMAP puts the
//   centre of the top-left pixel at (0.5, 0.5), this project at (0, 0): principal points and
//   keypoints are shifted by -0.5 px.
// - images -> client keyframes: pose (COLMAP's images.txt stores cam_from_world, as we do), all
//   2D points as keypoints (no orientation, octave 0, no descriptors: the text model has none);
//   timestamp = rank of the image name in sorted order, in seconds (COLMAP stores no time).
// - points3D -> point landmarks with their track as observations; the colour is dropped;
//   covariance to first order from the track:
//     Sigma_X = (sum_k J_k^T J_k / sigma_px^2 + I / prior_sigma^2)^-1,
//   J_k = d(pixel)/d(X) through the camera model, sigma_px = max(ERROR, min_sigma_px) with ERROR
//   the point's mean reprojection error from points3D.txt, and prior_sigma =
//   prior_sigma_scale * (median camera-to-point distance over all observations), a weak prior
//   in the model's own (arbitrary) scale that keeps Sigma_X finite for short baselines.
// - ids: ids are unique map-wide here but per table in COLMAP, so they are offset:
//     camera id   = COLMAP CAMERA_ID,
//     keyframe id = COLMAP IMAGE_ID + max CAMERA_ID,
//     point id    = COLMAP POINT3D_ID + max CAMERA_ID + max IMAGE_ID.
//   The offsets are recorded in the map's description.
//
// Errors: lcv::InputError naming the file and line ("model/images.txt:12: expected 10 fields
// ..."), for a missing file, a malformed line, an unsupported camera model, a dangling id or a
// track that disagrees with images.txt. The result passes mapping::ValidateMap.

#include <string>

#include "slam/data/map.h"

namespace lcv::mapping {

struct ColmapImportOptions {
  double min_sigma_px = 0.5;        // floor of the per-point pixel sigma
  double prior_sigma_scale = 10.0;  // see above; > 0
};

// dir holds cameras.txt, images.txt and points3D.txt.
slam::Map ReadColmapTextModel(const std::string& dir, const ColmapImportOptions& options = {});

}  // namespace lcv::mapping
