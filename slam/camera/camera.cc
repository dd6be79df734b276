#include "slam/camera/camera.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "slam/camera/equirectangular.h"
#include "slam/camera/fisheye.h"
#include "slam/camera/perspective.h"
#include "slam/util/error.h"

namespace lcv::slam {

double PixelAngle(const CameraParams& params) {
  if (params.model == CameraModel::kEquirectangular) {
    return params.cols > 0 ? 2.0 * M_PI / params.cols : 0.0;
  }
  return params.fx > 0.0 ? 1.0 / params.fx : 0.0;
}

const char* CameraModelName(CameraModel model) {
  switch (model) {
    case CameraModel::kPerspective:
      return "perspective";
    case CameraModel::kFisheye:
      return "fisheye";
    case CameraModel::kEquirectangular:
      return "equirectangular";
  }
  return "unknown";
}

std::optional<CameraModel> ParseCameraModel(const std::string& name) {
  if (name == "perspective" || name == "Perspective") return CameraModel::kPerspective;
  if (name == "fisheye" || name == "Fisheye") return CameraModel::kFisheye;
  if (name == "equirectangular" || name == "Equirectangular") {
    return CameraModel::kEquirectangular;
  }
  return std::nullopt;
}

std::optional<std::string> CameraParams::Problem() const {
  const auto fail = [](const std::string& field, double value, const char* rule) {
    std::ostringstream out;
    out << field << " must be " << rule << " (is " << value << ")";
    return std::optional<std::string>(out.str());
  };
  // Plausible ranges (docs/map-format.md): wide enough for any real camera, narrow enough that
  // no later arithmetic on them overflows or divides by ~0.
  if (cols < kMinImageSide || cols > kMaxImageSide) return fail("cols", cols, "in [8, 32768]");
  if (rows < kMinImageSide || rows > kMaxImageSide) return fail("rows", rows, "in [8, 32768]");
  if (std::max(cols, rows) > kMaxImageAspect * std::min(cols, rows)) {
    return fail("cols / rows", static_cast<double>(cols) / rows, "in [1/16, 16]");
  }
  if (!std::isfinite(fps) || fps <= 0 || fps > kMaxFps) return fail("fps", fps, "in (0, 10000]");
  if (model == CameraModel::kEquirectangular) return std::nullopt;

  // Pinhole part, shared by perspective and fisheye.
  const double side = std::max(cols, rows);
  const char* const focal_rule = "in [0.05, 1000] x the larger image side";
  if (!std::isfinite(fx) || fx < kMinFocalPerSide * side || fx > kMaxFocalPerSide * side) {
    return fail("fx", fx, focal_rule);
  }
  if (!std::isfinite(fy) || fy < kMinFocalPerSide * side || fy > kMaxFocalPerSide * side) {
    return fail("fy", fy, focal_rule);
  }
  if (!(fx <= kMaxPixelAspect * fy && fy <= kMaxPixelAspect * fx)) {
    return fail("fx / fy", fx / fy, "in [1/10, 10]");
  }
  if (!std::isfinite(cx) || cx < -cols || cx > 2.0 * cols) return fail("cx", cx, "in [-cols, 2 cols]");
  if (!std::isfinite(cy) || cy < -rows || cy > 2.0 * rows) return fail("cy", cy, "in [-rows, 2 rows]");
  static const char* const kPerspectiveNames[5] = {"k1", "k2", "p1", "p2", "k3"};
  static const char* const kFisheyeNames[5] = {"k1", "k2", "k3", "k4", "distortion[4]"};
  const char* const* names =
      model == CameraModel::kPerspective ? kPerspectiveNames : kFisheyeNames;
  for (int i = 0; i < 5; ++i) {
    if (!std::isfinite(distortion[i]) || std::abs(distortion[i]) > kMaxDistortionCoefficient) {
      return fail(names[i], distortion[i], "finite with magnitude <= 10000");
    }
  }
  // Below one degree of usable field of view the coefficients are certainly mistyped.
  constexpr double kMinValidAngleRad = M_PI / 180.0;
  if (model == CameraModel::kFisheye) {
    if (distortion[4] != 0.0) {
      return fail("distortion[4]", distortion[4], "0 for fisheye (it has k1..k4 only)");
    }
    const double max_angle = FisheyeCamera::MaxValidAngle(distortion);
    if (!(max_angle > kMinValidAngleRad)) {
      return fail("the fisheye's valid half field of view (rad)", max_angle,
                  "> 1 degree: k1..k4 fold the image right at its centre");
    }
  } else {
    const double max_angle = std::atan(PerspectiveCamera::MaxUndistortedRadius(distortion));
    if (!(max_angle > kMinValidAngleRad)) {
      return fail("the valid half field of view of the distortion (rad)", max_angle,
                  "> 1 degree: k1, k2, k3 fold the image right at its centre");
    }
  }
  return std::nullopt;
}

void Camera::ProjectBatch(const Eigen::Vector3d* p_in_cam, int count, Eigen::Vector2d* px,
                          unsigned char* valid) const {
  for (int i = 0; i < count; ++i) {
    const std::optional<Eigen::Vector2d> projected = Project(p_in_cam[i]);
    valid[i] = projected.has_value() ? 1 : 0;
    if (projected) px[i] = *projected;
  }
}

void Camera::UnprojectBatch(const Eigen::Vector2d* px, int count, Eigen::Vector3d* bearings,
                            unsigned char* valid) const {
  for (int i = 0; i < count; ++i) {
    const std::optional<Eigen::Vector3d> bearing = Unproject(px[i]);
    valid[i] = bearing.has_value() ? 1 : 0;
    if (bearing) bearings[i] = *bearing;
  }
}

std::unique_ptr<Camera> MakeCamera(const CameraParams& params) {
  const std::optional<std::string> problem = params.Problem();
  LCV_CHECK(!problem) << "camera '" << params.name << "': " << *problem;
  switch (params.model) {
    case CameraModel::kPerspective:
      return std::make_unique<PerspectiveCamera>(params);
    case CameraModel::kFisheye:
      return std::make_unique<FisheyeCamera>(params);
    case CameraModel::kEquirectangular:
      return std::make_unique<EquirectangularCamera>(params);
  }
  LCV_CHECK(false) << "unknown camera model " << static_cast<int>(params.model);
  return nullptr;
}

}  // namespace lcv::slam
