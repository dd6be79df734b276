#pragma once
// Camera models behind one bearing-vector interface (STYLE.md 2).
//
// Camera frame: x right, y down, z forward (OpenCV). A model maps a point in the camera frame to
// pixel coordinates (origin at the centre of the top-left pixel, x to the right, y down) and a
// pixel back to a unit bearing vector. The engine works on bearings, so that perspective, fisheye
// and equirectangular cameras run through the same code; no code outside slam/camera switches
// on the model.
//
// Thread safety: a Camera is immutable after construction; all methods are const and may be
// called concurrently.

#include <array>
#include <memory>
#include <optional>
#include <string>

#include <Eigen/Core>

namespace lcv::slam {

enum class CameraModel { kPerspective, kFisheye, kEquirectangular };

// "perspective", "fisheye", "equirectangular".
const char* CameraModelName(CameraModel model);
// Accepts the names above and stella_vslam's spellings ("Perspective", "Fisheye",
// "Equirectangular"). Empty for anything else.
std::optional<CameraModel> ParseCameraModel(const std::string& name);

// Intrinsics as in stella_vslam's camera settings. Units: pixels.
struct CameraParams {
  std::string name = "camera";
  CameraModel model = CameraModel::kPerspective;
  int cols = 0;  // image width, px
  int rows = 0;  // image height, px
  // Pinhole part (perspective, fisheye). Unused by equirectangular.
  double fx = 0, fy = 0, cx = 0, cy = 0;
  // perspective: {k1, k2, p1, p2, k3} (OpenCV radial-tangential);
  // fisheye: {k1, k2, k3, k4, 0} (Kannala-Brandt, as OpenCV's cv::fisheye);
  // equirectangular: unused.
  std::array<double, 5> distortion{};
  double fps = 30.0;

  // Plausible ranges checked by Problem() (documented in docs/map-format.md).
  static constexpr int kMinImageSide = 8, kMaxImageSide = 32768;  // px
  static constexpr int kMaxImageAspect = 16;                      // larger side / smaller side
  static constexpr double kMaxFps = 10000;
  static constexpr double kMinFocalPerSide = 0.05, kMaxFocalPerSide = 1000;  // fx, fy / side
  static constexpr double kMaxPixelAspect = 10;                   // fx / fy and fy / fx
  static constexpr double kMaxDistortionCoefficient = 1e4;

  // Empty when the parameters describe a usable camera, else what is wrong ("fx must be > 0").
  // Besides finiteness and signs, every value must lie in the plausible ranges above (cx in
  // [-cols, 2 cols], cy in [-rows, 2 rows]).
  std::optional<std::string> Problem() const;
};

// The angle one pixel subtends at the image centre (radians): 1 / fx for the pinhole models,
// 2 pi / cols for equirectangular; 0 for parameters without a focal length.
double PixelAngle(const CameraParams& params);

class Camera {
 public:
  virtual ~Camera() = default;

  const CameraParams& params() const { return params_; }
  CameraModel model() const { return params_.model; }
  int cols() const { return params_.cols; }
  int rows() const { return params_.rows; }

  // Pixel of a camera-frame point, with the 2x3 Jacobian d(px)/d(p_in_cam) when J_px_p is given.
  // Empty when the point cannot be imaged by the model (behind a perspective camera, beyond a
  // fisheye's valid angle, at the origin). Does not test whether the pixel is inside the image:
  // see InImage().
  virtual std::optional<Eigen::Vector2d> Project(const Eigen::Vector3d& p_in_cam,
                                                 Eigen::Matrix<double, 2, 3>* J_px_p = nullptr)
      const = 0;

  // Unit bearing of a pixel (any pixel, also outside the image bounds where the model is
  // defined). Empty where the model is not invertible.
  virtual std::optional<Eigen::Vector3d> Unproject(const Eigen::Vector2d& px) const = 0;

  // Largest angle (radians) between the optical axis (+z) and a bearing that the image can hold;
  // pi for equirectangular. Used to cull points before projecting.
  virtual double MaxViewAngle() const = 0;

  // True when px lies inside [margin, cols - 1 - margin] x [margin, rows - 1 - margin].
  bool InImage(const Eigen::Vector2d& px, double margin_px = 0.0) const {
    return px.x() >= margin_px && px.y() >= margin_px && px.x() <= cols() - 1 - margin_px &&
           px.y() <= rows() - 1 - margin_px;
  }

  // Batch forms, one virtual call per batch (STYLE.md 8). valid[i] is 1 where the single-point
  // call would return a value; the output element is unspecified otherwise.
  virtual void ProjectBatch(const Eigen::Vector3d* p_in_cam, int count, Eigen::Vector2d* px,
                            unsigned char* valid) const;
  virtual void UnprojectBatch(const Eigen::Vector2d* px, int count, Eigen::Vector3d* bearings,
                              unsigned char* valid) const;

 protected:
  explicit Camera(const CameraParams& params) : params_(params) {}
  CameraParams params_;
};

// The model named by params.model. Precondition: !params.Problem() (checked; throws
// std::logic_error otherwise; readers validate user files first).
std::unique_ptr<Camera> MakeCamera(const CameraParams& params);

}  // namespace lcv::slam
