#include "render/cube_map.h"

#include <cmath>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "render/synth_scenario.h"

namespace lcv::render {
namespace {

TEST(CubeFaceFromCam, FacesAreRotationsLookingAlongTheSixAxes) {
  const Eigen::Vector3d directions[kNumCubeFaces] = {
      Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitX(), -Eigen::Vector3d::UnitZ(),
      -Eigen::Vector3d::UnitX(), -Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitY()};
  for (int k = 0; k < kNumCubeFaces; ++k) {
    const Eigen::Matrix3d r = CubeFaceFromCam(k);
    EXPECT_NEAR((r * r.transpose() - Eigen::Matrix3d::Identity()).norm(), 0.0, 1e-15) << k;
    EXPECT_NEAR(r.determinant(), 1.0, 1e-15) << k;
    // The face's optical axis (its z) is the direction it looks along, in the camera frame.
    EXPECT_NEAR((r.transpose().col(2) - directions[k]).norm(), 0.0, 1e-15) << k;
  }
}

// A smooth colour field on the sphere: each channel an affine function of the bearing.
cv::Vec3f FieldColor(const Eigen::Vector3d& b) {
  return cv::Vec3f(static_cast<float>(128 + 100 * b.x()), static_cast<float>(128 + 100 * b.y()),
                   static_cast<float>(128 + 100 * b.z()));
}

// The atlas the renderer would produce for the field: each face pixel's bearing through the
// face's pinhole model.
cv::Mat FieldAtlas(const CubeMapResampler& resampler) {
  const int s = resampler.face_image_size();
  cv::Mat atlas(kNumCubeFaces * s, s, CV_32FC3);
  for (int k = 0; k < kNumCubeFaces; ++k) {
    const Eigen::Matrix3d cam_from_face = CubeFaceFromCam(k).transpose();
    for (int v = 0; v < s; ++v) {
      for (int u = 0; u < s; ++u) {
        const Eigen::Vector3d ray((u - resampler.face_principal_px()) / resampler.face_focal_px(),
                                  (v - resampler.face_principal_px()) / resampler.face_focal_px(),
                                  1.0);
        atlas.at<cv::Vec3f>(k * s + v, u) = FieldColor((cam_from_face * ray).normalized());
      }
    }
  }
  return atlas;
}

class CubeMapModels : public ::testing::TestWithParam<slam::CameraModel> {};

TEST_P(CubeMapModels, ResampledFieldMatchesTheCameraModel) {
  const slam::CameraParams params = SynthCamera(GetParam(), 320, 180);
  const auto camera = slam::MakeCamera(params);
  const CubeMapResampler resampler(*camera, CubeFaceSizeFor(*camera));
  const cv::Mat out = resampler.Resample(FieldAtlas(resampler));
  ASSERT_EQ(out.cols, params.cols);
  ASSERT_EQ(out.rows, params.rows);
  double max_error = 0.0;
  int checked = 0;
  for (int v = 0; v < params.rows; v += 3) {
    for (int u = 0; u < params.cols; u += 3) {
      const auto bearing = camera->Unproject(Eigen::Vector2d(u, v));
      if (!bearing) continue;
      const cv::Vec3f expected = FieldColor(*bearing), got = out.at<cv::Vec3f>(v, u);
      for (int c = 0; c < 3; ++c) max_error = std::max(max_error, double(std::abs(expected[c] - got[c])));
      ++checked;
    }
  }
  EXPECT_GT(checked, 5000);
  // A linear field is reproduced by bilinear lookup up to the face's curvature over one pixel
  // and the remap's 1/32 px fixed point: 100 * (1/32 px / f) << 1 level.
  EXPECT_LT(max_error, 1.0) << slam::CameraModelName(GetParam());
}

TEST_P(CubeMapModels, FaceSizeFollowsTheCameraResolution) {
  const auto small = slam::MakeCamera(SynthCamera(GetParam(), 320, 180));
  const auto large = slam::MakeCamera(SynthCamera(GetParam(), 640, 360));
  const int small_size = CubeFaceSizeFor(*small), large_size = CubeFaceSizeFor(*large);
  EXPECT_EQ(small_size % 2, 0);
  EXPECT_NEAR(large_size, 2.0 * small_size, 4.0);
  EXPECT_LT(large_size, 2 * 640);  // no blow-up (e.g. at equirectangular poles)
}

INSTANTIATE_TEST_SUITE_P(AllModels, CubeMapModels,
                         ::testing::Values(slam::CameraModel::kPerspective,
                                           slam::CameraModel::kFisheye,
                                           slam::CameraModel::kEquirectangular));

TEST(CubeMapResampler, OnlyNeededFacesAreUsed) {
  const auto perspective = slam::MakeCamera(SynthCamera(slam::CameraModel::kPerspective, 320, 180));
  const CubeMapResampler a(*perspective, 64);
  EXPECT_TRUE(a.used_faces()[0]);
  EXPECT_FALSE(a.used_faces()[2]);  // nothing behind an 80-degree camera
  const auto panorama = slam::MakeCamera(SynthCamera(slam::CameraModel::kEquirectangular, 320, 160));
  const CubeMapResampler b(*panorama, 64);
  for (int k = 0; k < kNumCubeFaces; ++k) EXPECT_TRUE(b.used_faces()[k]) << k;
}

}  // namespace
}  // namespace lcv::render
