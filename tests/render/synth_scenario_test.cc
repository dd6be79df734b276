#include "render/synth_scenario.h"

#include <algorithm>
#include <limits>

#include <gtest/gtest.h>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "render/scene_renderer.h"

namespace lcv::render {
namespace {

// Distance from a camera centre to the nearest centre of another path.
double DistanceToPath(const slam::Rigid3d& pose, const std::vector<slam::Rigid3d>& path) {
  double best = std::numeric_limits<double>::infinity();
  for (const auto& p : path) best = std::min(best, (p.Center() - pose.Center()).norm());
  return best;
}

// Share of client frames within radius_m of the map path.
double SharedFraction(const Scenario& s, double radius_m) {
  int near = 0;
  for (const auto& pose : s.client_cam_from_world) near += DistanceToPath(pose, s.map_cam_from_world) < radius_m;
  return static_cast<double>(near) / s.client_cam_from_world.size();
}

TEST(MakeScenario, EveryScenarioHasTwoSequencesAndAWellFormedScene) {
  for (const auto& name : ScenarioNames()) {
    const Scenario s = MakeScenario(name, 40, 7);
    EXPECT_EQ(s.map_cam_from_world.size(), 40u) << name;
    EXPECT_EQ(s.client_cam_from_world.size(), 40u) << name;
    EXPECT_GT(s.scene.quads.size(), 5u) << name;
    EXPECT_GT(s.scene.ground_truth_points.size(), 20u) << name;
    for (const auto& quad : s.scene.quads) {
      const cv::Mat& t = s.scene.textures.at(quad.texture_index);
      EXPECT_EQ(t.cols % 32, 0) << name;  // mip levels stay aligned (scene_renderer.h)
      EXPECT_EQ(t.rows % 32, 0) << name;
    }
    for (const auto& o : s.scene.objects) {
      EXPECT_TRUE((o.bbox_min.array() <= o.bbox_max.array()).all()) << name << " " << o.name;
    }
    for (const auto& p : s.scene.ground_truth_points) {
      const auto& o = s.scene.objects.at(p.object_id);
      EXPECT_TRUE(((p.position - o.bbox_min).array() >= -1e-9).all() &&
                  ((o.bbox_max - p.position).array() >= -1e-9).all())
          << name << " point " << p.id;
    }
  }
}

TEST(MakeScenario, OverlapsFollowTheProtocol) {
  const Scenario tracking = MakeScenario("tracking", 60, 0);
  EXPECT_EQ(SharedFraction(tracking, 1.5), 1.0);  // almost the same path (frames ~1.5 m apart)
  const Scenario overlap = MakeScenario("overlap", 60, 0);
  const double shared = SharedFraction(overlap, 2.0);
  EXPECT_GT(shared, 0.25);
  EXPECT_LT(shared, 0.6);
  const Scenario loop = MakeScenario("loop", 120, 0);
  // Starts in the mapped part, leaves it, and comes back to it at the end (loop closure).
  EXPECT_LT(DistanceToPath(loop.client_cam_from_world.front(), loop.map_cam_from_world), 2.0);
  EXPECT_LT(DistanceToPath(loop.client_cam_from_world.back(), loop.map_cam_from_world), 2.0);
  double farthest = 0;
  for (const auto& pose : loop.client_cam_from_world) {
    farthest = std::max(farthest, DistanceToPath(pose, loop.map_cam_from_world));
  }
  EXPECT_GT(farthest, 20.0);
}

TEST(MakeScenario, SameSeedSameSceneOtherSeedOtherScene) {
  const Scenario a = MakeScenario("loop", 5, 3), b = MakeScenario("loop", 5, 3), c = MakeScenario("loop", 5, 4);
  ASSERT_EQ(a.scene.textures.size(), b.scene.textures.size());
  for (size_t i = 0; i < a.scene.textures.size(); ++i) {
    EXPECT_EQ(cv::norm(a.scene.textures[i], b.scene.textures[i], cv::NORM_INF), 0.0);
  }
  EXPECT_TRUE(a.scene.quads.size() != c.scene.quads.size() ||
              cv::norm(a.scene.textures[0], c.scene.textures[0], cv::NORM_INF) > 0.0);
}

// The frames must be rich enough for ORB: many features, spread over the image.
TEST(MakeScenario, FramesAreRichInOrbFeatures) {
  const auto orb = cv::ORB::create(1000);
  for (const auto& name : ScenarioNames()) {
    const Scenario s = MakeScenario(name, 10, 0);
    SceneRenderer renderer(s.scene);
    const slam::CameraParams camera = SynthCamera(slam::CameraModel::kPerspective, 640, 360);
    cv::Mat gray;
    cv::cvtColor(renderer.Render(camera, s.map_cam_from_world[5], SequenceKind::kMap), gray,
                 cv::COLOR_BGR2GRAY);
    std::vector<cv::KeyPoint> keypoints;
    orb->detect(gray, keypoints);
    int cells[4][4] = {};
    for (const auto& k : keypoints) cells[int(k.pt.y * 4 / 360)][int(k.pt.x * 4 / 640)] = 1;
    int occupied = 0;
    for (auto& row : cells) for (int c : row) occupied += c;
    EXPECT_GE(keypoints.size(), 800u) << name;
    EXPECT_GE(occupied, 12) << name;
  }
}

}  // namespace
}  // namespace lcv::render
