#include "render/cube_map.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "slam/util/error.h"

namespace lcv::render {

Eigen::Matrix3d CubeFaceFromCam(int face) {
  Eigen::Matrix3d r;
  switch (face) {
    case 0: r << 1, 0, 0, 0, 1, 0, 0, 0, 1; break;     // front: z
    case 1: r << 0, 0, -1, 0, 1, 0, 1, 0, 0; break;    // right: x
    case 2: r << -1, 0, 0, 0, 1, 0, 0, 0, -1; break;   // back: -z
    case 3: r << 0, 0, 1, 0, 1, 0, -1, 0, 0; break;    // left: -x
    case 4: r << 1, 0, 0, 0, 0, 1, 0, -1, 0; break;    // up: -y (face y = cam z)
    case 5: r << 1, 0, 0, 0, 0, -1, 0, 1, 0; break;    // down: y (face y = -cam z)
    default: LCV_CHECK(false) << "cube face " << face;
  }
  return r;
}

int CubeFaceSizeFor(const slam::Camera& camera, double oversampling) {
  // Largest pixels-per-radian of the camera over a grid of pixel pairs. A face samples the
  // sphere with face_size / 2 px/rad at its centre (and more towards its edges).
  double max_px_per_rad = 0.0;
  const int steps = 16;
  for (int j = 0; j <= steps; ++j) {
    for (int i = 0; i <= steps; ++i) {
      const Eigen::Vector2d px((camera.cols() - 2) * i / double(steps),
                               (camera.rows() - 2) * j / double(steps));
      const auto a = camera.Unproject(px);
      const auto bx = camera.Unproject(px + Eigen::Vector2d(1, 0));
      const auto by = camera.Unproject(px + Eigen::Vector2d(0, 1));
      if (!a || !bx || !by) continue;
      // A pixel's coarser footprint: an equirectangular pixel near a pole is tiny across
      // longitude but not along latitude, and only the coarser side needs the cube's detail.
      const double angle = std::max(std::atan2(a->cross(*bx).norm(), a->dot(*bx)),
                                    std::atan2(a->cross(*by).norm(), a->dot(*by)));
      if (angle > 1e-9) max_px_per_rad = std::max(max_px_per_rad, 1.0 / angle);
    }
  }
  if (max_px_per_rad <= 0.0) max_px_per_rad = 0.5 * camera.cols();
  int size = static_cast<int>(std::ceil(2.0 * max_px_per_rad * oversampling));
  size = std::clamp(size + (size & 1), 16, 4096);
  return size;
}

CubeMapResampler::CubeMapResampler(const slam::Camera& camera, int face_size, int border,
                                   int supersampling)
    : face_size_(face_size), border_(border), supersampling_(supersampling),
      cols_(camera.cols()), rows_(camera.rows()) {
  LCV_CHECK(face_size >= 2 && border >= 1 && supersampling >= 1)
      << face_size << " " << border << " " << supersampling;
  const int k = supersampling;
  const int cols = camera.cols() * k, rows = camera.rows() * k;
  const int s = face_image_size();
  const double f = face_focal_px(), c = face_principal_px();
  std::array<Eigen::Matrix3d, kNumCubeFaces> face_from_cam;
  for (int k = 0; k < kNumCubeFaces; ++k) face_from_cam[k] = CubeFaceFromCam(k);

  std::vector<Eigen::Vector2d> pixels(static_cast<size_t>(cols));
  std::vector<Eigen::Vector3d> bearings(pixels.size());
  std::vector<unsigned char> valid(pixels.size());
  cv::Mat map_x(rows, cols, CV_32F), map_y(rows, cols, CV_32F);
  for (int v = 0; v < rows; ++v) {
    // Sample (u, v) of the k-times finer grid is at camera pixel ((u + 0.5) / k - 0.5, ...).
    for (int u = 0; u < cols; ++u) {
      pixels[u] = Eigen::Vector2d((u + 0.5) / k - 0.5, (v + 0.5) / k - 0.5);
    }
    camera.UnprojectBatch(pixels.data(), cols, bearings.data(), valid.data());
    float* mx = map_x.ptr<float>(v);
    float* my = map_y.ptr<float>(v);
    for (int u = 0; u < cols; ++u) {
      mx[u] = my[u] = -10.f;  // outside the atlas: black
      if (!valid[u]) continue;
      const Eigen::Vector3d& b = bearings[u];
      int face;
      const Eigen::Vector3d a = b.cwiseAbs();
      if (a.z() >= a.x() && a.z() >= a.y()) {
        face = b.z() > 0 ? 0 : 2;
      } else if (a.x() >= a.y()) {
        face = b.x() > 0 ? 1 : 3;
      } else {
        face = b.y() < 0 ? 4 : 5;
      }
      const Eigen::Vector3d p = face_from_cam[face] * b;
      used_faces_[face] = true;
      mx[u] = static_cast<float>(f * p.x() / p.z() + c);
      my[u] = static_cast<float>(f * p.y() / p.z() + c + face * s);
    }
  }
  cv::convertMaps(map_x, map_y, map_fixed_, map_interp_, CV_16SC2);
}

cv::Mat CubeMapResampler::Resample(const cv::Mat& atlas) const {
  LCV_CHECK(atlas.cols == face_image_size() && atlas.rows == kNumCubeFaces * face_image_size())
      << atlas.cols << "x" << atlas.rows;
  cv::Mat out;
  cv::remap(atlas, out, map_fixed_, map_interp_, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
            cv::Scalar::all(0));
  if (supersampling_ == 1) return out;
  cv::Mat averaged;
  cv::resize(out, averaged, cv::Size(cols_, rows_), 0, 0, cv::INTER_AREA);
  return averaged;
}

}  // namespace lcv::render
