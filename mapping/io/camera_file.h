#pragma once
// Camera files: the intrinsics of one camera in YAML or JSON, with stella_vslam's field names.
//
//   Camera:                      # optional section; the fields may also be at top level, or
//     name: "KITTI 00 left"      # flat as "Camera.fx: 718.856" (stella_vslam 0.2 / ORB-SLAM)
//     model: "perspective"       # perspective | fisheye | equirectangular
//     fx: 718.856                # pixels (not used by equirectangular)
//     fy: 718.856
//     cx: 607.1928
//     cy: 185.2157
//     k1: 0.0                    # perspective: k1 k2 p1 p2 k3 (OpenCV radial-tangential)
//     k2: 0.0                    # fisheye: k1 k2 k3 k4 (Kannala-Brandt, OpenCV cv::fisheye)
//     p1: 0.0                    # missing coefficients are 0
//     p2: 0.0
//     k3: 0.0
//     cols: 1241                 # image size in pixels ("width"/"height" accepted too)
//     rows: 376
//     fps: 10.0                  # optional, default 30
//
// The encoding is detected from the content (a first non-blank '{' means JSON), not the name.
// YAML is read by a strict subset parser (mapping/io/yaml_subset.h) that also accepts the
// "%YAML:1.0" header OpenCV writes. Other sections and fields (Feature:, setup, color_order, ...)
// are ignored, so a whole stella_vslam settings file is a valid camera file. ORB-SLAM's
// `Camera.type: "PinHole" | "KannalaBrandt8"` is accepted when `model` is absent.

#include <string>

#include "slam/camera/camera.h"

namespace lcv::mapping {

struct CameraFileOptions {
  // When false, missing cols/rows are left at 0 (dataset readers fill them from the first
  // image), and the result is not checked with CameraParams::Problem(): the caller must do it.
  bool require_image_size = true;
};

// Reads and validates a camera file. Throws lcv::InputError naming the file, the field and the
// value for anything missing or wrong ("cam.yaml: Camera.fx: expected a number, got \"abc\"",
// "cam.yaml: Camera: fx must be > 0").
slam::CameraParams ReadCameraFile(const std::string& path, const CameraFileOptions& options = {});
// Same from the file's bytes; source_name is used in error messages.
slam::CameraParams ParseCameraFile(const std::string& bytes, const std::string& source_name,
                                   const CameraFileOptions& options = {});

// Throws lcv::InputError("<source_name>: Camera: <problem>") when params.Problem() reports one.
void CheckCameraParams(const slam::CameraParams& params, const std::string& source_name);

// Writes params as YAML under a `Camera:` section, atomically (temporary file + rename), with
// numbers printed so that they read back bit-exact. Throws lcv::InputError on I/O failure.
void WriteCameraFile(const slam::CameraParams& params, const std::string& path);
std::string SerializeCameraFile(const slam::CameraParams& params);

// Shortest text that reads back as exactly value ("718.856", "0", "1e-09").
std::string FormatDoubleExact(double value);

}  // namespace lcv::mapping
