#include "render/scene_renderer.h"

#include <array>
#include <cmath>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "render/cube_map.h"
#include "render/gl_functions.h"
#include "render/offscreen_context.h"
#include "slam/util/error.h"

namespace lcv::render {
namespace {

using internal::Gl;

// Pinhole intrinsics of one rasterization (output camera or cube face).
struct Pinhole {
  int cols, rows;
  double fx, fy, cx, cy;
};

// Column-major GL projection taking a camera-frame point (x right, y down, z forward) to clip
// space so that pixel (u, v) = (fx x/z + cx, fy y/z + cy) lands on window (u + .5, rows - v - .5).
std::array<double, 16> ProjectionMatrix(const Pinhole& k, double near_m, double far_m) {
  std::array<double, 16> m{};
  m[0] = 2.0 * k.fx / k.cols;
  m[8] = 2.0 * (k.cx + 0.5) / k.cols - 1.0;
  m[5] = -2.0 * k.fy / k.rows;
  m[9] = 1.0 - 2.0 * (k.cy + 0.5) / k.rows;
  m[10] = (far_m + near_m) / (far_m - near_m);
  m[14] = -2.0 * far_m * near_m / (far_m - near_m);
  m[11] = 1.0;
  return m;
}

bool SameCamera(const slam::CameraParams& a, const slam::CameraParams& b) {
  return a.model == b.model && a.cols == b.cols && a.rows == b.rows && a.fx == b.fx &&
         a.fy == b.fy && a.cx == b.cx && a.cy == b.cy && a.distortion == b.distortion;
}

}  // namespace

struct SceneRenderer::Impl {
  SceneRenderOptions options;
  OffscreenContext context;
  std::vector<TexturedQuad> quads;
  std::vector<unsigned int> texture_names;  // GL names, by texture index
  std::vector<SceneObject> objects;
  cv::Scalar background;
  // Cube-map path, for the last non-direct camera.
  std::optional<slam::CameraParams> cube_camera;
  std::unique_ptr<CubeMapResampler> resampler;
  cv::Mat atlas;
  // Camera-frame vertices of one quad, reused.
  std::array<float, 12> vertices{};

  bool Visible(int object_id, SequenceKind sequence) const {
    for (const auto& o : objects) {
      if (o.id == object_id) return ObjectVisibleIn(o, sequence);
    }
    return true;
  }

  void UploadTextures(const Scene& scene) {
    context.Bind(16, 16);
    const auto& gl = Gl();
    texture_names.resize(scene.textures.size());
    if (texture_names.empty()) return;
    gl.GenTextures(static_cast<GLsizei>(texture_names.size()), texture_names.data());
    for (size_t i = 0; i < scene.textures.size(); ++i) {
      cv::Mat texture = scene.textures[i];
      LCV_CHECK(texture.type() == CV_8UC3 && !texture.empty()) << "texture " << i;
      if (!texture.isContinuous()) texture = texture.clone();
      gl.BindTexture(GL_TEXTURE_2D, texture_names[i]);
      gl.TexImage2D(GL_TEXTURE_2D, 0, GL_RGB8, texture.cols, texture.rows, 0, GL_BGR,
                    GL_UNSIGNED_BYTE, texture.data);
      gl.GenerateMipmap(GL_TEXTURE_2D);
      gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
      gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
      gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
      gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    }
    LCV_CHECK(gl.GetError() == GL_NO_ERROR) << "texture upload failed";
  }

  // Draws the scene into the bound buffer of size k.cols x k.rows.
  void Draw(const Pinhole& k, const slam::Rigid3d& cam_from_world, SequenceKind sequence) {
    const auto& gl = Gl();
    gl.ClearColor(static_cast<float>(background[2] / 255.0),
                  static_cast<float>(background[1] / 255.0),
                  static_cast<float>(background[0] / 255.0), 1.f);
    gl.ClearDepth(1.0);
    gl.Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    gl.Enable(GL_DEPTH_TEST);
    gl.DepthFunc(GL_LESS);
    gl.DepthMask(GL_TRUE);
    gl.Disable(GL_BLEND);
    gl.Disable(GL_CULL_FACE);
    gl.Disable(GL_LIGHTING);
    gl.Hint(GL_PERSPECTIVE_CORRECTION_HINT, GL_NICEST);
    gl.MatrixMode(GL_PROJECTION);
    const auto projection = ProjectionMatrix(k, options.near_m, options.far_m);
    gl.LoadMatrixd(projection.data());
    gl.MatrixMode(GL_MODELVIEW);
    gl.LoadIdentity();  // vertices are transformed to the camera frame here, in double
    gl.Enable(GL_TEXTURE_2D);
    gl.TexEnvi(GL_TEXTURE_ENV, GL_TEXTURE_ENV_MODE, GL_MODULATE);
    static constexpr float kTexCoords[8] = {0, 0, 1, 0, 1, 1, 0, 1};
    gl.EnableClientState(GL_VERTEX_ARRAY);
    gl.EnableClientState(GL_TEXTURE_COORD_ARRAY);
    gl.VertexPointer(3, GL_FLOAT, 0, vertices.data());
    gl.TexCoordPointer(2, GL_FLOAT, 0, kTexCoords);
    const Eigen::Matrix3d r = cam_from_world.RotationMatrix();
    const Eigen::Vector3d& t = cam_from_world.translation;
    for (const auto& quad : quads) {
      if (!Visible(quad.object_id, sequence)) continue;
      const Eigen::Vector3d corners[4] = {quad.origin, quad.origin + quad.edge_u,
                                          quad.origin + quad.edge_u + quad.edge_v,
                                          quad.origin + quad.edge_v};
      for (int c = 0; c < 4; ++c) {
        const Eigen::Vector3d p = r * corners[c] + t;
        for (int d = 0; d < 3; ++d) vertices[3 * c + d] = static_cast<float>(p[d]);
      }
      const auto level = static_cast<GLubyte>(std::lround(255.0 * std::clamp(quad.shade, 0.0, 1.0)));
      gl.Color4ub(level, level, level, 255);
      gl.BindTexture(GL_TEXTURE_2D, texture_names.at(quad.texture_index));
      gl.DrawArrays(GL_TRIANGLE_FAN, 0, 4);
    }
    gl.DisableClientState(GL_VERTEX_ARRAY);
    gl.DisableClientState(GL_TEXTURE_COORD_ARRAY);
    gl.Disable(GL_TEXTURE_2D);
  }
};

SceneRenderer::SceneRenderer(const Scene& scene, const SceneRenderOptions& options)
    : impl_(std::make_unique<Impl>()) {
  LCV_CHECK(options.supersampling >= 1) << "supersampling " << options.supersampling;
  impl_->options = options;
  impl_->quads = scene.quads;
  impl_->objects = scene.objects;
  impl_->background = scene.background_bgr;
  for (const auto& quad : scene.quads) {
    LCV_CHECK(quad.texture_index >= 0 &&
              quad.texture_index < static_cast<int>(scene.textures.size()))
        << "quad texture " << quad.texture_index;
  }
  impl_->UploadTextures(scene);
}

SceneRenderer::~SceneRenderer() = default;

bool SceneRenderer::RendersDirectly(const slam::CameraParams& camera) {
  if (camera.model != slam::CameraModel::kPerspective) return false;
  for (double d : camera.distortion) {
    if (d != 0.0) return false;
  }
  return true;
}

cv::Mat SceneRenderer::Render(const slam::CameraParams& camera,
                              const slam::Rigid3d& cam_from_world, SequenceKind sequence) {
  const int k = impl_->options.supersampling;
  if (RendersDirectly(camera)) {
    // Camera pixel u's centre is the mean of the centres of fine pixels k u .. k u + k - 1,
    // i.e. fine coordinate (u + 0.5) k - 0.5: INTER_AREA averages exactly those k x k pixels.
    impl_->context.Bind(camera.cols * k, camera.rows * k);
    impl_->Draw({camera.cols * k, camera.rows * k, camera.fx * k, camera.fy * k,
                 (camera.cx + 0.5) * k - 0.5, (camera.cy + 0.5) * k - 0.5},
                cam_from_world, sequence);
    if (k == 1) return impl_->context.ReadBgr();
    cv::Mat averaged;
    cv::resize(impl_->context.ReadBgr(), averaged, cv::Size(camera.cols, camera.rows), 0, 0,
               cv::INTER_AREA);
    return averaged;
  }
  if (!impl_->cube_camera || !SameCamera(*impl_->cube_camera, camera)) {
    const auto model = slam::MakeCamera(camera);
    impl_->resampler = std::make_unique<CubeMapResampler>(
        *model, CubeFaceSizeFor(*model, impl_->options.cube_oversampling * k), 2, k);
    impl_->cube_camera = camera;
  }
  const CubeMapResampler& resampler = *impl_->resampler;
  const int s = resampler.face_image_size();
  impl_->atlas.create(kNumCubeFaces * s, s, CV_8UC3);
  impl_->atlas.setTo(cv::Scalar::all(0));
  const Pinhole face{s, s, resampler.face_focal_px(), resampler.face_focal_px(),
                     resampler.face_principal_px(), resampler.face_principal_px()};
  impl_->context.Bind(s, s);
  for (int k = 0; k < kNumCubeFaces; ++k) {
    if (!resampler.used_faces()[k]) continue;
    const Eigen::Quaterniond face_from_cam(CubeFaceFromCam(k));
    const slam::Rigid3d face_from_world =
        slam::Rigid3d(face_from_cam, Eigen::Vector3d::Zero()) * cam_from_world;
    impl_->Draw(face, face_from_world, sequence);
    impl_->context.ReadBgr().copyTo(impl_->atlas.rowRange(k * s, (k + 1) * s));
  }
  return resampler.Resample(impl_->atlas);
}

}  // namespace lcv::render
