#include "slam/match/line_projection_matcher.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "render/synth_scenario.h"
#include "slam/match/epipolar_matcher.h"
#include "tests/slam/match/line_match_scene.h"

namespace lcv::slam {
namespace {

CameraParams Equirectangular(int cols, int rows) {
  CameraParams params;
  params.model = CameraModel::kEquirectangular;
  params.cols = cols;
  params.rows = rows;
  return params;
}

using testing::LineScene;
using testing::LineSceneOptions;

class LineMatcherModelTest : public ::testing::TestWithParam<CameraModel> {
 protected:
  LineScene MakeScene(std::uint64_t seed) const {
    LineSceneOptions options;
    options.model = GetParam();
    options.seed = seed;
    return testing::MakeLineScene(options);
  }
};

std::string ModelName(const ::testing::TestParamInfo<CameraModel>& info) {
  return CameraModelName(info.param);
}

TEST_P(LineMatcherModelTest, FindsTheHiddenPointsAtTheTrueAndAPerturbedPose) {
  const std::uint64_t seed = 11;
  SCOPED_TRACE("seed " + std::to_string(seed));
  const LineScene scene = MakeScene(seed);
  Vector6d delta;  // 2 cm and ~0.2 degrees: a constant-velocity prediction's error
  delta << 0.02, -0.01, 0.005, 0.002, -0.003, 0.001;
  for (const Rigid3d& pose : {scene.cam_from_world, Rigid3d::Exp(delta) * scene.cam_from_world}) {
    Frame frame = testing::MakeLineSceneFrame(scene);
    LineMatchScratch scratch;
    std::vector<LineMatch> matches;
    const int count =
        MatchLinesByProjection(scene.lines, pose, LineMatchOptions(), &frame, &scratch, &matches);
    const testing::LineMatchScore score = testing::ScoreLineMatches(scene, frame);
    EXPECT_EQ(count, score.correct + score.wrong);
    EXPECT_EQ(static_cast<int>(matches.size()), count);
    EXPECT_GT(score.findable, 500);
    EXPECT_GT(score.Recall(), 0.9) << score.correct << " of " << score.findable;
    EXPECT_LE(score.wrong, 0.01 * count) << score.wrong << " wrong of " << count;
    // Each match lies inside its line's interval and, for correct ones, the ray-closest
    // parameter is near the hidden point (a few cm at a few metres, from pixel noise).
    int near_hidden = 0, correct = 0;
    for (const LineMatch& m : matches) {
      EXPECT_EQ(frame.landmark_ids[m.keypoint_index], m.line_id);
      const int j = static_cast<int>(m.line_id - LineScene::kFirstLineId);
      EXPECT_GE(m.s, scene.lines[j].s_min);
      EXPECT_LE(m.s, scene.lines[j].s_max);
      if (scene.point_of_keypoint[m.keypoint_index] != j) continue;
      ++correct;
      const double depth = (pose * scene.hidden_points[j]).norm();
      near_hidden += std::abs(m.s - scene.hidden_s[j]) < 0.5 * depth;
    }
    // The parameter is ill-conditioned only for lines nearly along the ray.
    EXPECT_GT(near_hidden, 0.9 * correct);
  }
}

TEST_P(LineMatcherModelTest, DoesNotMatchAHiddenPointOutsideTheInterval) {
  const std::uint64_t seed = 12;
  SCOPED_TRACE("seed " + std::to_string(seed));
  LineScene scene = MakeScene(seed);
  const LineMatchOptions options;
  // Move the interval of every line whose hidden point has a keypoint beyond the hidden point,
  // far enough that no sample projects near it: the bearing of the interval's start is
  // 5 search radii of angle away from the hidden point's bearing.
  const double min_angle = 5.0 * options.radius_px * RadiansPerPixel(*scene.camera);
  std::vector<int> moved_lines;
  for (int i = 0; i < static_cast<int>(scene.keypoints.size()); ++i) {
    const int j = scene.point_of_keypoint[i];
    if (j < 0) continue;
    LineMatchCandidate& line = scene.lines[j];
    const Eigen::Vector3d center = scene.cam_from_world.Center();
    const Eigen::Vector3d hidden_bearing = (scene.hidden_points[j] - center).normalized();
    // The angle grows monotonically along the line away from the hidden point.
    double offset = 0.01;
    while (offset < 1e3 &&
           std::acos(std::clamp((line.line.PointAt(scene.hidden_s[j] + offset) - center)
                                    .normalized()
                                    .dot(hidden_bearing),
                                -1.0, 1.0)) < min_angle) {
      offset *= 1.5;
    }
    if (offset >= 1e3) continue;  // a line along the viewing ray: no interval can exclude it
    line.s_min = scene.hidden_s[j] + offset;
    line.s_max = std::max(line.s_max, line.s_min + 5.0);
    moved_lines.push_back(j);
  }
  ASSERT_GT(moved_lines.size(), 300u);
  Frame frame = testing::MakeLineSceneFrame(scene);
  LineMatchScratch scratch;
  MatchLinesByProjection(scene.lines, scene.cam_from_world, options, &frame, &scratch);
  for (int i = 0; i < frame.num_keypoints(); ++i) {
    const int j = scene.point_of_keypoint[i];
    if (j < 0 || frame.landmark_ids[i] == kInvalidId) continue;
    const bool moved = std::find(moved_lines.begin(), moved_lines.end(), j) != moved_lines.end();
    EXPECT_FALSE(moved && frame.landmark_ids[i] == scene.lines[j].line_id)
        << "line " << j << " matched to its hidden point outside its interval";
  }
  // The same lines with their true intervals are found: the exclusion was the interval's doing.
  const LineScene original = MakeScene(seed);
  Frame frame2 = testing::MakeLineSceneFrame(original);
  MatchLinesByProjection(original.lines, original.cam_from_world, options, &frame2, &scratch);
  int found = 0;
  for (int i = 0; i < frame2.num_keypoints(); ++i) {
    const int j = original.point_of_keypoint[i];
    found += j >= 0 && frame2.landmark_ids[i] == original.lines[j].line_id;
  }
  EXPECT_GT(found, 0.9 * moved_lines.size());
}

TEST_P(LineMatcherModelTest, LeavesAlreadyMatchedKeypointsAlone) {
  const LineScene scene = MakeScene(13);
  Frame frame = testing::MakeLineSceneFrame(scene);
  // Every other keypoint already holds a point landmark; a third of those are outliers.
  for (int i = 0; i < frame.num_keypoints(); i += 2) {
    frame.landmark_ids[i] = 7;
    frame.is_outlier[i] = (i % 3 == 0) ? 1 : 0;
  }
  const std::vector<Id> before_ids = frame.landmark_ids;
  const std::vector<std::uint8_t> before_outliers = frame.is_outlier;
  LineMatchScratch scratch;
  std::vector<LineMatch> matches;
  const int count = MatchLinesByProjection(scene.lines, scene.cam_from_world, LineMatchOptions(),
                                           &frame, &scratch, &matches);
  EXPECT_GT(count, 0);
  for (int i = 0; i < frame.num_keypoints(); i += 2) {
    EXPECT_EQ(frame.landmark_ids[i], before_ids[i]);
    EXPECT_EQ(frame.is_outlier[i], before_outliers[i]);
  }
  for (const LineMatch& m : matches) EXPECT_EQ(m.keypoint_index % 2, 1);
  // One keypoint per line and one line per keypoint.
  std::vector<Id> ids;
  for (const LineMatch& m : matches) ids.push_back(m.line_id);
  std::sort(ids.begin(), ids.end());
  EXPECT_EQ(std::unique(ids.begin(), ids.end()), ids.end());
}

TEST_P(LineMatcherModelTest, SearchGridAndFrameGridGiveTheSameMatches) {
  const LineScene scene = MakeScene(14);
  std::vector<std::vector<LineMatch>> results;
  for (const int cell : {0, 4, 8, 16}) {
    Frame frame = testing::MakeLineSceneFrame(scene);
    for (int i = 0; i < frame.num_keypoints(); i += 5) frame.landmark_ids[i] = 3;  // some held
    LineMatchOptions options;
    options.search_cell_px = cell;
    LineMatchScratch scratch;
    results.emplace_back();
    MatchLinesByProjection(scene.lines, scene.cam_from_world, options, &frame, &scratch,
                           &results.back());
  }
  ASSERT_GT(results[0].size(), 300u);
  for (size_t r = 1; r < results.size(); ++r) {
    ASSERT_EQ(results[r].size(), results[0].size());
    for (size_t m = 0; m < results[0].size(); ++m) {
      EXPECT_EQ(results[r][m].keypoint_index, results[0][m].keypoint_index);
      EXPECT_EQ(results[r][m].line_id, results[0][m].line_id);
    }
  }
}

TEST_P(LineMatcherModelTest, WorkerThreadsGiveTheSameMatchesAndCounts) {
  const LineScene scene = MakeScene(15);
  std::vector<std::vector<LineMatch>> results;
  std::vector<int> projections, window_hits;
  LineMatchScratch scratch;  // reused: its pool is restarted when the thread count changes
  for (const int threads : {1, 2, 4, 2}) {
    Frame frame = testing::MakeLineSceneFrame(scene);
    for (int i = 0; i < frame.num_keypoints(); i += 5) frame.landmark_ids[i] = 3;  // some held
    LineMatchOptions options;
    options.num_threads = threads;
    results.emplace_back();
    MatchLinesByProjection(scene.lines, scene.cam_from_world, options, &frame, &scratch,
                           &results.back());
    projections.push_back(scratch.num_projections);
    window_hits.push_back(scratch.num_window_hits);
  }
  ASSERT_GT(results[0].size(), 300u);
  for (size_t r = 1; r < results.size(); ++r) {
    EXPECT_EQ(projections[r], projections[0]);
    EXPECT_EQ(window_hits[r], window_hits[0]);
    ASSERT_EQ(results[r].size(), results[0].size());
    for (size_t m = 0; m < results[0].size(); ++m) {
      EXPECT_EQ(results[r][m].keypoint_index, results[0][m].keypoint_index);
      EXPECT_EQ(results[r][m].line_id, results[0][m].line_id);
      EXPECT_EQ(results[r][m].s, results[0][m].s);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(AllModels, LineMatcherModelTest,
                         ::testing::Values(CameraModel::kPerspective, CameraModel::kFisheye,
                                           CameraModel::kEquirectangular),
                         ModelName);

TEST(LineMatcherTest, EmptyInputAndEmptyIntervalsMatchNothing) {
  LineSceneOptions options;
  options.num_lines = 200;
  LineScene scene = testing::MakeLineScene(options);
  Frame frame = testing::MakeLineSceneFrame(scene);
  LineMatchScratch scratch;
  EXPECT_EQ(MatchLinesByProjection({}, scene.cam_from_world, LineMatchOptions(), &frame, &scratch),
            0);
  for (auto& line : scene.lines) std::swap(line.s_min, line.s_max);  // s_min > s_max: skipped
  EXPECT_EQ(MatchLinesByProjection(scene.lines, scene.cam_from_world, LineMatchOptions(), &frame,
                                   &scratch),
            0);
  EXPECT_EQ(scratch.num_samples, 0);
}

CameraParams Pinhole();

// A frame of one keypoint at px with descriptor d, seen from the identity pose.
Frame OneKeypointFrame(const Camera& camera, const Eigen::Vector2d& px, const OrbDescriptor& d) {
  Frame frame;
  frame.camera = &camera;
  Keypoint kp;
  kp.x = static_cast<float>(px.x());
  kp.y = static_cast<float>(px.y());
  frame.keypoints = {kp};
  frame.descriptors = {d};
  PrepareFrame(&frame);
  return frame;
}

TEST(LineMatcherTest, LineThroughTheCameraCentreImagesToOnePixel) {
  const auto camera = MakeCamera(Pinhole());
  LineMatchCandidate line;
  line.line_id = 9;
  line.line = Line3d(Eigen::Vector3d::Zero(), Eigen::Vector3d(0.1, 0.05, 1.0).normalized());
  line.s_min = 1.0;
  line.s_max = 9.0;
  line.descriptor.fill(0x5a);
  const Eigen::Vector2d px = *camera->Project(line.line.direction);
  Frame frame = OneKeypointFrame(*camera, px, line.descriptor);
  LineMatchScratch scratch;
  std::vector<LineMatch> matches;
  ASSERT_EQ(
      MatchLinesByProjection({line}, Rigid3d(), LineMatchOptions(), &frame, &scratch, &matches), 1);
  EXPECT_EQ(frame.landmark_ids[0], 9u);
  EXPECT_GE(matches[0].s, 1.0);
  EXPECT_LE(matches[0].s, 9.0);
  // Behind the camera (the interval on the other side of the centre): nothing.
  line.s_min = -9.0;
  line.s_max = -1.0;
  frame.ResetMatches();
  EXPECT_EQ(MatchLinesByProjection({line}, Rigid3d(), LineMatchOptions(), &frame, &scratch), 0);
}

TEST(LineMatcherTest, EquirectangularWindowsContinueAcrossTheSeam) {
  const auto camera = MakeCamera(Equirectangular(640, 320));
  // A point behind the camera just left of the seam (x ~ 1 px); the line runs sideways so
  // that its interval, starting 6 cm to the right, projects just right of the seam (x ~ 639.8).
  const Eigen::Vector3d hidden(-0.05, 0.0, -5.0);
  LineMatchCandidate line;
  line.line_id = 21;
  line.line = Line3d(Eigen::Vector3d(0.0, 0.0, -5.0), Eigen::Vector3d::UnitX());
  line.s_min = line.line.Parameter(hidden) + 0.06;
  line.s_max = line.s_min + 1.0;
  line.descriptor.fill(0x3c);
  const Eigen::Vector2d px = *camera->Project(hidden);
  ASSERT_LT(px.x(), 2.0);
  ASSERT_GT(camera->Project(line.line.PointAt(line.s_min))->x(), camera->params().cols - 1.0);
  Frame frame = OneKeypointFrame(*camera, px, line.descriptor);
  LineMatchScratch scratch;
  EXPECT_EQ(MatchLinesByProjection({line}, Rigid3d(), LineMatchOptions(), &frame, &scratch), 1);
  // A perspective camera does not wrap: the same pixel far from that curve finds nothing.
  const auto pinhole = MakeCamera(Pinhole());
  Frame frame2 = OneKeypointFrame(*pinhole, Eigen::Vector2d(1.0, 240.0), line.descriptor);
  line.line = Line3d(Eigen::Vector3d(0.0, 0.0, 5.0), Eigen::Vector3d::UnitX());
  line.s_min = 3.0;  // right edge of the image: u = 500 x / 5 + 319.5 >= 619.5
  line.s_max = 3.19;
  EXPECT_EQ(MatchLinesByProjection({line}, Rigid3d(), LineMatchOptions(), &frame2, &scratch), 0);
}

TEST(LineMatcherTest, SamplesPerLineAreCapped) {
  const auto camera = MakeCamera(Pinhole());
  LineMatchCandidate line;
  line.line_id = 4;
  line.line = Line3d(Eigen::Vector3d(0, 0, 0.5), Eigen::Vector3d::UnitX());  // close and long
  line.s_min = -100.0;
  line.s_max = 100.0;
  line.descriptor.fill(0x11);
  // The keypoint where the line crosses the image centre column.
  Frame frame =
      OneKeypointFrame(*camera, *camera->Project(Eigen::Vector3d(0, 0, 0.5)), line.descriptor);
  LineMatchOptions options;
  options.step_px = 1.0;
  options.max_samples_per_line = 50;
  // The cap coarsens this line's step to ~30 px (3.1 rad of extent over 50 samples at 0.002
  // rad/px): a window that wide still covers the gaps.
  options.radius_px = 20.f;
  LineMatchScratch scratch;
  EXPECT_EQ(MatchLinesByProjection({line}, Rigid3d(), options, &frame, &scratch), 1);
  EXPECT_LE(scratch.num_projections, 50);
  EXPECT_GT(scratch.num_samples, 10);  // the samples spread over the image, not bunched
}

// The viewing test on a known answer: an equirectangular camera at the origin, a line along x
// at z = 5, its hidden point at s = 0 (x = s), the viewers' centroid at z = 10, behind the point.
// The angle between the camera's ray (s, 0, 5) and the viewers' ray (s, 0, -5) is at most 60
// degrees where (s^2 - 25) / (s^2 + 25) >= 0.5, i.e. |s| >= 5 sqrt(3): the stretch |s| < 8.66
// (bearing angle |phi| < 60 degrees of the walk's +-75.96) is not projected, both distances are
// equal (the scale test passes everywhere).
TEST(LineMatcherTest, ViewingTestSkipsSamplesSeenFromWhereTheServerNeverLooked) {
  const auto camera = MakeCamera(Equirectangular(640, 320));
  LineMatchCandidate line;
  line.line_id = 31;
  line.line = Line3d(Eigen::Vector3d(0.0, 0.0, 5.0), Eigen::Vector3d::UnitX());
  line.s_min = -20.0;
  line.s_max = 20.0;
  line.descriptor.fill(0x6b);
  const auto match_at = [&](double s, const LineMatchCandidate& candidate,
                            const LineMatchOptions& options, LineMatchScratch* scratch) {
    Frame frame = OneKeypointFrame(*camera, *camera->Project(candidate.line.PointAt(s)),
                                   candidate.descriptor);
    return MatchLinesByProjection({candidate}, Rigid3d(), options, &frame, scratch);
  };
  LineMatchScratch scratch;
  const LineMatchOptions options;
  // Without viewers nothing is skipped.
  EXPECT_EQ(match_at(0.0, line, options, &scratch), 1);
  EXPECT_EQ(scratch.num_culled, 0);
  const int all_projections = scratch.num_projections;

  line.has_viewers = true;
  line.viewers_centroid = Eigen::Vector3d(0.0, 0.0, 10.0);
  EXPECT_EQ(match_at(0.0, line, options, &scratch), 0);
  // 120 of the walk's 151.9 degrees at the nominal step (12 px x 0.5625 degrees per px).
  const double step_deg = options.step_px * 360.0 / camera->params().cols;
  EXPECT_NEAR(scratch.num_culled, 120.0 / step_deg, 1.5);
  EXPECT_NEAR(scratch.num_projections, all_projections - 120.0 / step_deg, 1.5);
  EXPECT_EQ(match_at(12.0, line, options, &scratch), 1);   // 44 degrees off the viewers' ray
  EXPECT_EQ(match_at(-12.0, line, options, &scratch), 1);
  EXPECT_EQ(match_at(7.5, line, options, &scratch), 0);    // 67 degrees
  LineMatchOptions no_angle;
  no_angle.max_view_angle_deg = 180.0;
  EXPECT_EQ(match_at(0.0, line, no_angle, &scratch), 1);
  EXPECT_EQ(scratch.num_culled, 0);

  // Scale: viewers on the camera's ray to the point but 105 away, the camera 5 away: 5 / 105 <
  // 0.8 / 1.2^7 = 0.223 (default pyramid: 8 levels, factor 1.2).
  line.viewers_centroid = Eigen::Vector3d(0.0, 0.0, -100.0);
  EXPECT_EQ(match_at(0.0, line, options, &scratch), 0);
  LineMatchOptions no_scale;
  no_scale.check_scale_range = false;
  EXPECT_EQ(match_at(0.0, line, no_scale, &scratch), 1);
  // Viewers at the camera's centre: the same rays and distances, nothing skipped.
  line.viewers_centroid = Eigen::Vector3d::Zero();
  EXPECT_EQ(match_at(0.0, line, options, &scratch), 1);
  EXPECT_EQ(scratch.num_culled, 0);
  EXPECT_EQ(scratch.num_projections, all_projections);
}

// A camera at the origin looking along +z: 640x480, f = 500, principal point at the centre.
CameraParams Pinhole() {
  CameraParams p;
  p.model = CameraModel::kPerspective;
  p.cols = 640;
  p.rows = 480;
  p.fx = p.fy = 500.0;
  p.cx = 319.5;
  p.cy = 239.5;
  return p;
}

// cam_from_world of a camera at center with the world's axes.
Rigid3d At(const Eigen::Vector3d& center) {
  return Rigid3d(Eigen::Quaterniond::Identity(), -center);
}

TEST(LineVisibleIntervalTest, PerspectiveKeyframesIntersect) {
  const auto camera = MakeCamera(Pinhole());
  // The line z = 5, y = 0 along x: u = 500 x / 5 + 319.5 in [0, 639] <=> |x| <= 3.195.
  const Line3d line(Eigen::Vector3d(0, 0, 5), Eigen::Vector3d::UnitX());
  const auto one = LineVisibleInterval(line, {At({0, 0, 0})}, {camera.get()}, 0.1, 100.0);
  ASSERT_TRUE(one);
  EXPECT_NEAR(one->first, -3.195, 1e-6);
  EXPECT_NEAR(one->second, 3.195, 1e-6);
  // A second keyframe 1 m to the right sees x in [-2.195, 4.195].
  const auto two = LineVisibleInterval(line, {At({0, 0, 0}), At({1, 0, 0})},
                                       {camera.get(), camera.get()}, 0.1, 100.0);
  ASSERT_TRUE(two);
  EXPECT_NEAR(two->first, -2.195, 1e-6);
  EXPECT_NEAR(two->second, 3.195, 1e-6);
  // The distance bound: |x| <= sqrt(5.5^2 - 5^2).
  const auto near = LineVisibleInterval(line, {At({0, 0, 0})}, {camera.get()}, 0.1, 5.5);
  ASSERT_TRUE(near);
  EXPECT_NEAR(near->first, -std::sqrt(5.5 * 5.5 - 25.0), 1e-6);
  EXPECT_NEAR(near->second, std::sqrt(5.5 * 5.5 - 25.0), 1e-6);
  // The anchor does not matter: the same line anchored elsewhere gives the shifted interval.
  const Line3d shifted(Eigen::Vector3d(2, 0, 5), Eigen::Vector3d::UnitX());
  const auto moved = LineVisibleInterval(shifted, {At({0, 0, 0})}, {camera.get()}, 0.1, 100.0);
  ASSERT_TRUE(moved);
  EXPECT_NEAR(moved->first, -5.195, 1e-6);
  EXPECT_NEAR(moved->second, 1.195, 1e-6);
}

TEST(LineVisibleIntervalTest, EmptyWhenNoPartIsSeenByAll) {
  const auto camera = MakeCamera(Pinhole());
  const Line3d line(Eigen::Vector3d(0, 0, 5), Eigen::Vector3d::UnitX());
  // A keyframe looking the other way (rotated 180 degrees about y) does not see it.
  const Rigid3d backwards(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY())),
                          Eigen::Vector3d::Zero());
  EXPECT_FALSE(LineVisibleInterval(line, {At({0, 0, 0}), backwards}, {camera.get(), camera.get()},
                                   0.1, 100.0));
  // Two keyframes whose views of the line do not overlap: x in [-3.2, 3.2] and [6.8, 13.2].
  EXPECT_FALSE(LineVisibleInterval(line, {At({0, 0, 0}), At({10, 0, 0})},
                                   {camera.get(), camera.get()}, 0.1, 100.0));
  // Too far, too near, no keyframe.
  EXPECT_FALSE(LineVisibleInterval(line, {At({0, 0, 0})}, {camera.get()}, 0.1, 4.0));
  EXPECT_FALSE(LineVisibleInterval(line, {At({0, 0, 0})}, {camera.get()}, 7.0, 100.0));
  EXPECT_FALSE(LineVisibleInterval(line, {}, {}, 0.1, 100.0));
  EXPECT_THROW(LineVisibleInterval(line, {At({0, 0, 0})}, {}, 0.1, 100.0), std::logic_error);
}

TEST(LineVisibleIntervalTest, EquirectangularSeesAllAroundUpToTheDistance) {
  const auto camera = MakeCamera(Equirectangular(1280, 640));
  const Line3d line(Eigen::Vector3d(0, 0, 5), Eigen::Vector3d::UnitX());
  // Whole sphere: only the distance limits it, |x| <= sqrt(10^2 - 5^2), behind the camera too.
  const auto one = LineVisibleInterval(line, {At({0, 0, 0})}, {camera.get()}, 0.1, 10.0);
  ASSERT_TRUE(one);
  EXPECT_NEAR(one->first, -std::sqrt(75.0), 1e-6);
  EXPECT_NEAR(one->second, std::sqrt(75.0), 1e-6);
  // With a second panorama 6 m along x: x in [6 - sqrt(75), sqrt(75)].
  const auto two = LineVisibleInterval(line, {At({0, 0, 0}), At({6, 0, 0})},
                                       {camera.get(), camera.get()}, 0.1, 10.0);
  ASSERT_TRUE(two);
  EXPECT_NEAR(two->first, 6.0 - std::sqrt(75.0), 1e-6);
  EXPECT_NEAR(two->second, std::sqrt(75.0), 1e-6);
  // A line behind a panorama is seen too (unlike a perspective camera).
  const Line3d behind(Eigen::Vector3d(0, 0, -5), Eigen::Vector3d::UnitX());
  EXPECT_TRUE(LineVisibleInterval(behind, {At({0, 0, 0})}, {camera.get()}, 0.1, 10.0));
}

// Property: the returned ends are real visibility boundaries for every model: just inside them
// every keyframe sees the line, just outside some keyframe does not.
TEST(LineVisibleIntervalTest, EndsAreVisibilityBoundariesForAllModels) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (const CameraModel model :
       {CameraModel::kPerspective, CameraModel::kFisheye, CameraModel::kEquirectangular}) {
    const auto camera = MakeCamera(render::SynthCamera(model, 640, 360));
    const double min_distance = 0.3, max_distance = 20.0;
    int checked = 0;
    for (int trial = 0; trial < 200; ++trial) {
      const Eigen::Vector3d point(uniform(rng) * 4 - 2, uniform(rng) * 2 - 1, 3 + 5 * uniform(rng));
      const Line3d line(point, UniformUnitVector(uniform(rng), uniform(rng)));
      std::vector<Rigid3d> poses;
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector3d center = 0.5 * UniformUnitVector(uniform(rng), uniform(rng));
        poses.push_back(Rigid3d(ExpSO3(0.1 * UniformUnitVector(uniform(rng), uniform(rng))),
                                Eigen::Vector3d::Zero()) *
                        At(center));
      }
      const std::vector<const Camera*> cameras(3, camera.get());
      const auto seen_by_all = [&](double s) {
        for (const Rigid3d& pose : poses) {
          const Eigen::Vector3d p = pose * line.PointAt(s);
          if (p.norm() < min_distance || p.norm() > max_distance) return false;
          const auto px = camera->Project(p);
          if (!px || !camera->InImage(*px)) return false;
        }
        return true;
      };
      const auto interval = LineVisibleInterval(line, poses, cameras, min_distance, max_distance);
      if (!interval) {
        // Then no sampled parameter near the hidden point is seen by all.
        for (double s = -10; s <= 10; s += 0.01) ASSERT_FALSE(seen_by_all(s)) << s;
        continue;
      }
      const double eps = 1e-4;
      ASSERT_GT(interval->second - interval->first, 2 * eps);
      EXPECT_TRUE(seen_by_all(interval->first + eps)) << CameraModelName(model);
      EXPECT_TRUE(seen_by_all(interval->second - eps)) << CameraModelName(model);
      EXPECT_FALSE(seen_by_all(interval->first - eps)) << CameraModelName(model);
      EXPECT_FALSE(seen_by_all(interval->second + eps)) << CameraModelName(model);
      ++checked;
    }
    EXPECT_GT(checked, 50) << CameraModelName(model);
  }
}

}  // namespace
}  // namespace lcv::slam
