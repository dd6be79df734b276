#pragma once
// Renders a textured Scene (render/scene.h) as seen by a camera of any model, offscreen.
//
// Perspective cameras without distortion are rasterized directly with a projection that puts
// camera pixel (u, v) (origin at the centre of the top-left pixel, camera.h) exactly at GL pixel
// centre (u + 0.5, rows - v - 0.5), so a world point X lands at camera.Project(cam_from_world * X).
// Every other camera (fisheye, equirectangular, distorted perspective) is resampled from a cube
// map rendered around the camera centre (render/cube_map.h) through slam::Camera::Unproject.
//
// Textures are mip-mapped (trilinear) so that distant ground does not alias into spurious
// corners. Anisotropic filtering is deliberately off: llvmpipe's anisotropic sampling is not
// centred and shifts oblique texture detail by up to ~1 px (measured on the ground-truth
// markers: max error 1.1 px with it, 0.3 px without). No lighting: a quad's colour is its
// texture times shade.
//
// Supersampling (options.supersampling = k > 1) renders k x k samples per camera pixel and
// averages them (cv::INTER_AREA), as a sensor pixel integrates its footprint: directly, at k
// times the resolution with the principal point at (c + 0.5) k - 0.5 so that the fine pixels
// of camera pixel u average exactly to u's centre; through the cube map, with a lookup table
// at sub-pixel positions (u + (i + 0.5) / k - 0.5) and faces k times finer. Point sampling
// (k = 1) with trilinear mip-mapping over-blurs oblique texture by an amount that changes with
// distance, and the FAST corners of those textures creep: a monocular SLAM map of the
// `overlap` street shrinks ~1.5% over its 57 m with k = 1 and ~0.7% with k = 3
// (docs/datasets.md, "Supersampling"). k = 1 stays the library default for cheap unit tests;
// `lcv synth` uses 3.
//
// Determinism: the same scene, camera and pose give the same bytes, in one process and across
// runs (OSMesa llvmpipe, pinned GL state).
//
// Thread safety: not thread-safe; one renderer per thread. It owns an OSMesa context.

#include <memory>

#include <opencv2/core/mat.hpp>

#include "render/scene.h"
#include "slam/camera/camera.h"
#include "slam/geometry/rigid3.h"

namespace lcv::render {

struct SceneRenderOptions {
  double near_m = 0.05;    // near clipping distance along the optical axis / cube faces, m
  double far_m = 2000.0;   // far clipping distance, m
  double cube_oversampling = 1.0;   // cube face resolution relative to the camera's finest
  int supersampling = 1;   // k x k samples per pixel, averaged (see above); >= 1
};

class SceneRenderer {
 public:
  // Uploads the scene's textures. The renderer copies what it needs; scene may be destroyed.
  // Throws std::runtime_error when no OSMesa context can be created.
  explicit SceneRenderer(const Scene& scene, const SceneRenderOptions& options = {});
  ~SceneRenderer();
  SceneRenderer(const SceneRenderer&) = delete;
  SceneRenderer& operator=(const SceneRenderer&) = delete;

  // The image (CV_8UC3 BGR, camera.cols x camera.rows) of the objects visible in `sequence`.
  // Precondition: !camera.Problem(). The cube-map lookup table of a non-perspective camera is
  // built on the first call and reused while the camera parameters stay the same.
  cv::Mat Render(const slam::CameraParams& camera, const slam::Rigid3d& cam_from_world,
                 SequenceKind sequence);

  // True when Render draws this camera directly (no cube map).
  static bool RendersDirectly(const slam::CameraParams& camera);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace lcv::render
