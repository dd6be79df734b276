// The server side of a bundle in a line cloud (AddLineCloudToBundle, slam/optimize/
// slam_map_bundle.h), as local BA uses it with LineCloud.local_ba_frees_line_cloud: which server
// keyframes join free, which hold the border, and that free lines follow the client where the
// server's own view cannot tell where they are.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include <gtest/gtest.h>

#include "slam/optimize/bundle_adjustment.h"
#include "slam/optimize/slam_map_bundle.h"
#include "tests/slam/module/line_cloud_scene.h"
#include "tests/slam/module/loop_scene.h"

namespace lcv::slam {
namespace {

using testing::AddLineCloud;
using testing::LoopScene;
using testing::LoopSceneOptions;
using testing::MakeLoopScene;
using testing::RestoreOnLines;

// Every client keyframe (fixed or free) and every landmark of the map in a problem.
BundleProblem ClientProblem(const SlamMap& map, bool fixed_keyframes) {
  BundleProblem problem;
  SlamMapBundleBuilder builder(map, &problem);
  for (const auto& [id, kf] : map.keyframes()) builder.AddKeyframe(id, fixed_keyframes);
  for (const auto& [id, landmark] : map.landmarks()) builder.AddLandmark(id);
  return problem;
}

std::unique_ptr<LoopScene> RegisteredRing() {
  LoopSceneOptions options;
  options.num_keyframes = 12;
  options.drift_start = options.drift_end = 1000;  // client keyframes at their true poses
  std::unique_ptr<LoopScene> s = MakeLoopScene(options);
  return s;
}

// Replaces every line of the cloud by move(line, the server keyframe that sees it, the index of
// its scene point): what earlier bundles (or the server's own errors) did to it.
template <typename Move>
void MoveEveryLine(const std::vector<Id>& line_of_point, LoopScene* s, Move move) {
  for (size_t j = 0; j < line_of_point.size(); ++j) {
    if (line_of_point[j] == kInvalidId) continue;
    SlamLine* line = s->map.FindLine(line_of_point[j]);
    const SlamServerKeyframe& kf = s->map.server_keyframes().at(line->server_keyframe_ids[0]);
    line->line = move(line->line, kf, j);
  }
}

TEST(LineCloudBundle, JoinsTheServerKeyframesThatSeeTheMostRestoredLines) {
  const std::unique_ptr<LoopScene> s = RegisteredRing();
  const std::vector<Id> line_of_point = AddLineCloud({0, 3, 6, 9}, 5, s.get());
  ASSERT_GT(RestoreOnLines(line_of_point, 11, s.get()), 200);
  // X' lines seen per server keyframe, from the map.
  std::map<Id, int> restored_seen;
  for (const auto& [id, kf] : s->map.server_keyframes()) {
    for (const Id line_id : kf.line_ids) {
      restored_seen[id] += s->map.FindLine(line_id)->restored_landmark_id != kInvalidId;
    }
  }
  std::vector<std::pair<int, Id>> ranked;
  for (const auto& [id, n] : restored_seen) {
    if (n > 0) ranked.emplace_back(-n, id);
  }
  std::sort(ranked.begin(), ranked.end());
  ASSERT_GE(ranked.size(), 3u);

  // 0: every server keyframe fixed; 1: one joins, the others are the border; all: the border is
  // empty, so the two joined ones that see the fewest X' lines hold the gauge.
  for (const int max_free : {0, 1, static_cast<int>(ranked.size())}) {
    SCOPED_TRACE(max_free);
    BundleProblem problem = ClientProblem(s->map, /*fixed_keyframes=*/false);
    const size_t num_restored_lines = problem.lines.size();
    LineCloudBundleOptions options;
    options.free_server_keyframes = true;
    options.max_free_server_keyframes = max_free;
    const std::vector<Id> line_ids = AddLineCloudToBundle(s->map, options, &problem);
    ASSERT_EQ(line_ids.size(), problem.lines.size());
    // Lines of the scene are seen by one server keyframe each: only the X' lines join.
    EXPECT_EQ(problem.lines.size(), num_restored_lines);
    for (const BundleLine& l : problem.lines) EXPECT_FALSE(l.fixed);
    std::set<Id> expected_free;
    const int border = static_cast<int>(ranked.size()) - max_free;
    const int gauge = border >= 2 ? 0 : std::min(max_free, 2 - border);
    for (int k = 0; k < max_free - gauge; ++k) expected_free.insert(ranked[k].second);
    std::set<Id> free, fixed;
    for (const BundleServerKeyframe& k : problem.server_keyframes) {
      (k.fixed ? fixed : free).insert(k.id);
    }
    EXPECT_EQ(free, expected_free);
    EXPECT_EQ(free.size() + fixed.size(), ranked.size());  // the border: the others
    // One virtual observation per (server keyframe, line of the problem) pair.
    size_t pairs = 0;
    for (const BundleServerKeyframe& k : problem.server_keyframes) {
      for (const Id line_id : s->map.server_keyframes().at(k.id).line_ids) {
        pairs += std::count(line_ids.begin(), line_ids.end(), line_id);
      }
    }
    EXPECT_EQ(problem.virtual_observations.size(), pairs);
  }
}

TEST(LineCloudBundle, FreeLinesFollowTheClientAlongTheServersViewingRays) {
  // The server map's depths are 4% too large (its monocular scale): every line moved along the
  // ray from its server keyframe through its point, which keeps the line in that keyframe's view
  // plane, so its virtual observation cannot see the error. The client's keyframes (true poses,
  // fixed: the border of a local BA) see the points where they are.
  const std::unique_ptr<LoopScene> s = RegisteredRing();
  const std::vector<Id> line_of_point = AddLineCloud({0, 3, 6, 9}, 5, s.get());
  MoveEveryLine(line_of_point, s.get(),
                [&](const Line3d& line, const SlamServerKeyframe& kf, size_t j) {
                  const Eigen::Vector3d ray =
                      s->scene.points_in_world[j] - kf.cam_from_world.Center();
                  return Line3d(line.anchor + 0.04 * ray, line.direction);
                });
  ASSERT_GT(RestoreOnLines(line_of_point, 11, s.get()), 200);
  auto error = [&](const BundleProblem& problem, const std::vector<Id>& line_ids, bool of_lines) {
    double sum = 0.0;
    int n = 0;
    for (size_t i = 0; i < problem.lines.size(); ++i) {
      const Id line_id = line_ids.empty() ? s->map.FindLandmark(problem.lines[i].id)->line_id
                                          : line_ids[i];
      const auto it = std::find(line_of_point.begin(), line_of_point.end(), line_id);
      const Eigen::Vector3d& truth = s->scene.points_in_world[it - line_of_point.begin()];
      sum += of_lines ? problem.lines[i].line.Residual(truth).squaredNorm()
                      : (problem.lines[i].restored_point - truth).squaredNorm();
      ++n;
    }
    return std::sqrt(sum / n);
  };

  BundleOptions options;
  options.max_iterations = 20;
  // Lines fixed (the paper's local BA): X' can leave its line only as far as Omega_L allows.
  BundleProblem fixed_lines = ClientProblem(s->map, /*fixed_keyframes=*/true);
  const double lines_before = error(fixed_lines, {}, true);
  ASSERT_TRUE(SolveBundleAdjustment(options, &fixed_lines).success);
  const double restored_fixed = error(fixed_lines, {}, false);
  // Lines free, server keyframes fixed (local_ba_free_server_keyframes 0).
  BundleProblem free_lines = ClientProblem(s->map, /*fixed_keyframes=*/true);
  const std::vector<Id> line_ids =
      AddLineCloudToBundle(s->map, LineCloudBundleOptions{}, &free_lines);
  ASSERT_TRUE(SolveBundleAdjustment(options, &free_lines).success);
  const double lines_after = error(free_lines, line_ids, true);
  const double restored_free = error(free_lines, line_ids, false);
  std::printf("lines %.4f -> %.4f m from their points; X' %.4f m (lines fixed) vs %.4f m (free)\n",
              lines_before, lines_after, restored_fixed, restored_free);
  EXPECT_LT(lines_after, 0.25 * lines_before);
  EXPECT_LT(restored_free, 0.5 * restored_fixed);
  // The server keyframes still see each line where they saw it.
  for (const BundleVirtualObservation& v : free_lines.virtual_observations) {
    const BundleServerKeyframe& kf = free_lines.server_keyframes[v.server_keyframe];
    const Line3d& line = free_lines.lines[v.line].line;
    const Eigen::Vector3d in_cam_anchor = kf.cam_from_world * line.anchor;
    const Eigen::Vector3d in_cam_direction = kf.cam_from_world.rotation * line.direction;
    const Eigen::Vector3d normal = in_cam_anchor.cross(in_cam_direction).normalized();
    EXPECT_GT(std::abs(normal.dot(v.observed_normal)), 1.0 - 1e-4);
  }
}

TEST(LineCloudBundle, VirtualObservationsFromThePublishedLinesPullMovedLinesBack) {
  // Earlier bundles moved every line out of its server keyframe's view plane (by 3% of the
  // distance, along the plane's normal). Virtual observations made from that state hold the
  // lines where they went; made from the lines as published (the paper's L0) they see the move.
  const std::unique_ptr<LoopScene> s = RegisteredRing();
  const std::vector<Id> line_of_point = AddLineCloud({0, 3, 6, 9}, 5, s.get());
  MoveEveryLine(line_of_point, s.get(),
                [](const Line3d& line, const SlamServerKeyframe& kf, size_t) {
                  const Eigen::Vector3d to_line = line.anchor - kf.cam_from_world.Center();
                  const Eigen::Vector3d normal = to_line.cross(line.direction).normalized();
                  return Line3d(line.anchor + 0.03 * to_line.norm() * normal, line.direction);
                });
  ASSERT_GT(RestoreOnLines(line_of_point, 11, s.get()), 200);
  auto line_error = [&](const BundleProblem& problem, const std::vector<Id>& line_ids) {
    double sum = 0.0;
    for (size_t i = 0; i < problem.lines.size(); ++i) {
      const auto it = std::find(line_of_point.begin(), line_of_point.end(), line_ids[i]);
      sum += problem.lines[i].line.Residual(s->scene.points_in_world[it - line_of_point.begin()])
                 .squaredNorm();
    }
    return std::sqrt(sum / problem.lines.size());
  };
  BundleOptions options;
  options.max_iterations = 20;
  double after[2] = {0.0, 0.0};
  for (const bool from_published : {false, true}) {
    SCOPED_TRACE(from_published);
    // Client keyframes fixed at their true poses; X' and lines free (local BA's setting).
    BundleProblem problem = ClientProblem(s->map, /*fixed_keyframes=*/true);
    LineCloudBundleOptions line_cloud;
    line_cloud.virtual_from_published = from_published;
    const std::vector<Id> line_ids = AddLineCloudToBundle(s->map, line_cloud, &problem);
    ASSERT_FALSE(problem.virtual_observations.empty());
    // Each observation is the plane through the keyframe and the published line, or the
    // current one.
    for (const BundleVirtualObservation& v : problem.virtual_observations) {
      const SlamLine& line = *s->map.FindLine(line_ids[v.line]);
      const Line3d& seen = from_published ? line.published_line : line.line;
      const Rigid3d& pose = problem.server_keyframes[v.server_keyframe].cam_from_world;
      const Eigen::Vector3d normal =
          (pose * seen.anchor).cross(pose.rotation * seen.direction).normalized();
      EXPECT_GT(std::abs(normal.dot(v.observed_normal)), 1.0 - 1e-9);
    }
    const double before = line_error(problem, line_ids);
    ASSERT_TRUE(SolveBundleAdjustment(options, &problem).success);
    after[from_published] = line_error(problem, line_ids);
    std::printf("v from the %s lines: %.4f -> %.4f m from their points\n",
                from_published ? "published" : "current", before, after[from_published]);
  }
  EXPECT_LT(after[1], 0.5 * after[0]);
}

TEST(LineCloudBundle, VirtualSigmaInPixelsOfTheServerCamera) {
  // LineCloudBundleOptions::virtual_sigma_px: every virtual observation's information is
  // 1 / (sigma_px x the server camera's pixel angle)^2; 0 leaves BundleOptions' constant.
  const std::unique_ptr<LoopScene> s = RegisteredRing();
  const std::vector<Id> line_of_point = AddLineCloud({0, 3, 6, 9}, 5, s.get());
  ASSERT_GT(RestoreOnLines(line_of_point, 11, s.get()), 200);
  const CameraParams& camera = s->map.server_cameras().begin()->second;
  ASSERT_GT(camera.fx, 0.0);
  for (const double sigma_px : {0.0, 1.0, 2.5}) {
    SCOPED_TRACE(sigma_px);
    BundleProblem problem = ClientProblem(s->map, /*fixed_keyframes=*/true);
    LineCloudBundleOptions line_cloud;
    line_cloud.virtual_from_published = sigma_px > 1.0;  // both ways of making v
    line_cloud.virtual_sigma_px = sigma_px;
    AddLineCloudToBundle(s->map, line_cloud, &problem);
    ASSERT_FALSE(problem.virtual_observations.empty());
    const Eigen::Matrix2d expected = sigma_px > 0.0
                                         ? Eigen::Matrix2d(Eigen::Matrix2d::Identity() * camera.fx / sigma_px)
                                         : Eigen::Matrix2d::Zero();
    for (const BundleVirtualObservation& v : problem.virtual_observations) {
      EXPECT_LT((v.sqrt_information - expected).norm(), 1e-9 * (1.0 + expected.norm()));
    }
  }
}

TEST(PixelAngle, IsOnePixelAtTheImageCentreForEachModel) {
  CameraParams perspective;
  perspective.fx = 500.0;
  EXPECT_DOUBLE_EQ(PixelAngle(perspective), 1.0 / 500.0);
  CameraParams equirectangular;
  equirectangular.model = CameraModel::kEquirectangular;
  equirectangular.cols = 1024;
  EXPECT_DOUBLE_EQ(PixelAngle(equirectangular), 2.0 * M_PI / 1024.0);
  EXPECT_EQ(PixelAngle(CameraParams{}), 0.0);  // no focal length
}

}  // namespace
}  // namespace lcv::slam
