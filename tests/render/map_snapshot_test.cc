#include "render/map_snapshot.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "mapping/io/atomic_file.h"
#include "mapping/io/map_file.h"
#include "mapping/line_cloud.h"
#include "mapping/synthetic_map.h"

namespace lcv::render {
namespace {

namespace fs = std::filesystem;

slam::CameraParams TestCamera() {
  slam::CameraParams c;
  c.model = slam::CameraModel::kPerspective;
  c.cols = 640;
  c.rows = 360;
  c.fx = c.fy = 400;
  c.cx = 319.5;
  c.cy = 179.5;
  return c;
}

// Camera at (0, 0, -5) looking along +z (world y down, like a first camera frame).
slam::Rigid3d FrontPose(double x) {
  return slam::Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-x, 0, 5));
}

// A small map: a grid of points on the plane z = 5, lines through some of them in random
// directions, one restored point, two client keyframes and one server keyframe.
slam::Map KnownMap() {
  slam::Map map;
  map.cameras[1] = TestCamera();
  slam::Id id = 10;
  for (int i = -3; i <= 3; ++i) {
    for (int j = -2; j <= 2; ++j) {
      slam::PointLandmark p;
      p.id = id++;
      p.position = Eigen::Vector3d(1.0 * i, 0.8 * j, 5.0);
      map.points[p.id] = p;
    }
  }
  const Eigen::Vector3d directions[3] = {Eigen::Vector3d(1, 0.2, 0.1).normalized(),
                                         Eigen::Vector3d(0.1, 1, 0.3).normalized(),
                                         Eigen::Vector3d(0.7, -0.7, 0.2).normalized()};
  for (int k = 0; k < 3; ++k) {
    slam::LineLandmark l;
    l.id = id++;
    l.line = slam::Line3d(Eigen::Vector3d(-1.5 + 1.5 * k, 0.4, 6.0), directions[k]);
    l.information = slam::LineInformation(l.line.direction, Eigen::Matrix3d::Identity());
    if (k == 1) l.restored_point = l.line.PointAt(0.3);
    map.lines[l.id] = l;
  }
  for (int k = 0; k < 2; ++k) {
    slam::Keyframe kf;
    kf.id = id++;
    kf.camera_id = 1;
    kf.timestamp = k;
    kf.cam_from_world = FrontPose(0.5 * k);
    map.keyframes[kf.id] = kf;
  }
  slam::ServerKeyframe skf;
  skf.id = id++;
  skf.camera_id = 1;
  skf.timestamp = 5;
  skf.cam_from_world = FrontPose(2.0);
  map.server_keyframes[skf.id] = skf;
  return map;
}

cv::Vec3b At(const cv::Mat& image, const Eigen::Vector2d& px) {
  return image.at<cv::Vec3b>(static_cast<int>(std::lround(px.y())), static_cast<int>(std::lround(px.x())));
}

bool IsBlue(const cv::Vec3b& bgr) { return bgr[0] > 150 && bgr[2] < 130 && bgr[0] > bgr[1] + 40; }

// A 1-px line lights one pixel per column (or row), which may be a neighbour of the rounded
// projection: look in the 3x3 neighbourhood.
bool BlueNear(const cv::Mat& image, const Eigen::Vector2d& px) {
  for (int dv = -1; dv <= 1; ++dv) {
    for (int du = -1; du <= 1; ++du) {
      if (IsBlue(At(image, px + Eigen::Vector2d(du, dv)))) return true;
    }
  }
  return false;
}

TEST(MapSnapshot, KeyframeViewShowsPointsAndLinesWhereTheyProject) {
  const slam::Map map = KnownMap();
  SnapshotOptions options;
  options.cols = 640;
  options.rows = 360;
  options.view = SnapshotView::kKeyframe;
  options.keyframe_id = map.keyframes.begin()->first;
  const Snapshot snapshot = RenderMapSnapshot(map, options);
  ASSERT_EQ(snapshot.image.cols, 640);
  ASSERT_EQ(snapshot.image.type(), CV_8UC3);
  // Same camera as the keyframe: its projection is the keyframe's pinhole projection.
  const slam::Rigid3d& pose = map.keyframes.begin()->second.cam_from_world;
  int black = 0;
  for (const auto& [id, p] : map.points) {
    const Eigen::Vector3d q = pose * p.position;
    const Eigen::Vector2d expected(400 * q.x() / q.z() + 319.5, 400 * q.y() / q.z() + 179.5);
    const auto px = snapshot.camera.Project(p.position);
    ASSERT_TRUE(px);
    EXPECT_LT((*px - expected).norm(), 1e-9);
    if (expected.x() < 2 || expected.y() < 2 || expected.x() > 637 || expected.y() > 357) continue;
    EXPECT_EQ(At(snapshot.image, expected), cv::Vec3b(0, 0, 0)) << "point " << id;
    ++black;
  }
  EXPECT_GT(black, 20);
  // Lines: sample along each clipped segment, away from points; the pixels are blue.
  const MapFrame frame = ComputeMapFrame(map);
  int blue = 0, samples = 0;
  for (const auto& [id, l] : map.lines) {
    const auto segment = ClipLineToBox(l.line, frame);
    ASSERT_TRUE(segment) << id;
    for (double a = 0.05; a < 1.0; a += 0.05) {
      const Eigen::Vector3d x = segment->first + a * (segment->second - segment->first);
      const auto px = snapshot.camera.Project(x);
      if (!px || px->x() < 3 || px->y() < 3 || px->x() > 636 || px->y() > 356) continue;
      bool near_point = false;
      for (const auto& [pid, p] : map.points) {
        const auto pp = snapshot.camera.Project(p.position);
        near_point |= pp && (*pp - *px).norm() < 4;
      }
      if (near_point) continue;
      ++samples;
      blue += BlueNear(snapshot.image, *px);
    }
  }
  ASSERT_GT(samples, 20);
  EXPECT_EQ(blue, samples);
}

TEST(MapSnapshot, TopViewShowsKeyframesAndRestoredPoints) {
  const slam::Map map = KnownMap();
  SnapshotOptions options;
  options.view = SnapshotView::kTop;
  const Snapshot snapshot = RenderMapSnapshot(map, options);
  ASSERT_TRUE(snapshot.camera.orthographic);
  // The server keyframe's frustum apex is red, the client ones' green.
  const auto server = snapshot.camera.Project(map.server_keyframes.begin()->second.cam_from_world.Center());
  const cv::Vec3b s = At(snapshot.image, *server);
  EXPECT_TRUE(s[2] > 150 && s[1] < 80 && s[0] < 80) << s;
  const auto client = snapshot.camera.Project(map.keyframes.begin()->second.cam_from_world.Center());
  const cv::Vec3b c = At(snapshot.image, *client);
  EXPECT_TRUE(c[1] > 100 && c[2] < 80 && c[0] < 80) << c;
  for (const auto& [id, l] : map.lines) {
    if (!l.restored_point) continue;
    const cv::Vec3b r = At(snapshot.image, *snapshot.camera.Project(*l.restored_point));
    EXPECT_EQ(r, cv::Vec3b(0, 140, 255)) << "restored point of line " << id;
  }
}

// Issue 16 item 1: a map with lines and one coordinate of 1e154 (its square overflows) crashed
// LineLayer::Draw with NaN pixels. The file reader refuses such maps now; the renderer must
// still never crash on one built in memory.
TEST(MapSnapshot, HugeCoordinatesDoNotCrash) {
  for (const double huge : {1e154, 1e200, -1e308}) {
    for (const SnapshotView view : {SnapshotView::kTop, SnapshotView::kOblique}) {
      slam::Map map = KnownMap();
      map.points.begin()->second.position.x() = huge;
      map.lines.begin()->second.line.anchor.y() = huge;
      SnapshotOptions options;
      options.view = view;
      options.cols = 320;
      options.rows = 180;
      const Snapshot snapshot = RenderMapSnapshot(map, options);
      EXPECT_EQ(snapshot.image.cols, 320) << huge;
    }
  }
}

TEST(MapSnapshot, LinesStayInsideTheMapBoundingBox) {
  mapping::SyntheticMapOptions synthetic;
  synthetic.num_points = 400;
  synthetic.num_keyframes = 10;
  slam::Map cloud = mapping::ConvertToLineCloud(mapping::MakeSyntheticPointMap(synthetic), {});
  cloud.server_keyframes.clear();  // only lines: every drawn pixel belongs to a line
  const MapFrame frame = ComputeMapFrame(cloud);
  for (const auto& [id, l] : cloud.lines) {
    const auto segment = ClipLineToBox(l.line, frame);
    if (!segment) continue;
    for (const auto& end : {segment->first, segment->second}) {
      const Eigen::Vector3d q = frame.ToFrame(end);
      EXPECT_TRUE(((q - frame.box_min).array() >= -1e-9).all() && ((frame.box_max - q).array() >= -1e-9).all());
      // An end point lies on the box surface.
      EXPECT_LT(std::min((q - frame.box_min).cwiseAbs().minCoeff(), (frame.box_max - q).cwiseAbs().minCoeff()), 1e-9);
    }
    EXPECT_LT(l.line.Distance(segment->first), 1e-9);
  }
  SnapshotOptions options;
  options.view = SnapshotView::kTop;
  options.cols = 400;
  options.rows = 300;
  const Snapshot snapshot = RenderMapSnapshot(cloud, options);
  // Projected box corners bound every non-white pixel.
  Eigen::Vector2d lo(1e9, 1e9), hi(-1e9, -1e9);
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d corner((k & 1) ? frame.box_max.x() : frame.box_min.x(),
                                 (k & 2) ? frame.box_max.y() : frame.box_min.y(),
                                 (k & 4) ? frame.box_max.z() : frame.box_min.z());
    const Eigen::Vector2d px = *snapshot.camera.Project(frame.ToWorld(corner));
    lo = lo.cwiseMin(px);
    hi = hi.cwiseMax(px);
  }
  int drawn = 0, outside = 0;
  for (int v = 0; v < snapshot.image.rows; ++v) {
    for (int u = 0; u < snapshot.image.cols; ++u) {
      if (snapshot.image.at<cv::Vec3b>(v, u) == cv::Vec3b(255, 255, 255)) continue;
      ++drawn;
      outside += u < lo.x() - 1.5 || v < lo.y() - 1.5 || u > hi.x() + 1.5 || v > hi.y() + 1.5;
    }
  }
  EXPECT_GT(drawn, 2000);
  EXPECT_EQ(outside, 0);
}

TEST(MapSnapshot, SameInputSamePixelsAndBytes) {
  const slam::Map map = KnownMap();
  for (const auto view : {SnapshotView::kTop, SnapshotView::kOblique}) {
    SnapshotOptions options;
    options.view = view;
    options.legend = true;
    MapSnapshotRenderer renderer;
    const cv::Mat a = renderer.Render(map, options).image;
    const cv::Mat b = RenderMapSnapshot(map, options).image;
    EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
    const std::string dir = ::testing::TempDir();
    WritePng(a, dir + "/snap_a.png");
    WritePng(b, dir + "/snap_b.png");
    EXPECT_EQ(mapping::ReadFileBytes(dir + "/snap_a.png"), mapping::ReadFileBytes(dir + "/snap_b.png"));
  }
}

TEST(MapSnapshot, RiskColoursAndLegend) {
  slam::Map map = KnownMap();
  map.points.clear();
  SnapshotOptions options;
  options.view = SnapshotView::kKeyframe;
  options.keyframe_id = map.keyframes.begin()->first;
  options.color_by = SnapshotColorBy::kRisk;
  const slam::Id risky = map.lines.begin()->first, safe = std::next(map.lines.begin())->first;
  options.line_risk[risky] = 1.0;
  options.line_risk[safe] = 0.0;
  const Snapshot snapshot = RenderMapSnapshot(map, options);
  const MapFrame frame = ComputeMapFrame(map);
  const auto colour_at_middle = [&](slam::Id id) {
    const auto segment = ClipLineToBox(map.lines.at(id).line, frame);
    return At(snapshot.image, *snapshot.camera.Project(0.5 * (segment->first + segment->second)));
  };
  const cv::Vec3b red = colour_at_middle(risky), blue = colour_at_middle(safe);
  EXPECT_TRUE(red[2] > 150 && red[0] < 100) << red;
  EXPECT_TRUE(IsBlue(blue)) << blue;
  options.legend = true;
  const cv::Mat with_legend = RenderMapSnapshot(map, options).image;
  cv::Mat diff;
  cv::absdiff(with_legend, snapshot.image, diff);
  EXPECT_GT(cv::countNonZero(diff.reshape(1)), 1000);
}

std::string RunCommand(const std::string& command) {
  std::string output;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (!pipe) return "";
  char buffer[512];
  while (std::fgets(buffer, sizeof(buffer), pipe)) output += buffer;
  const int status = ::pclose(pipe);
  return WIFEXITED(status) ? std::to_string(WEXITSTATUS(status)) + ":" + output : "signal";
}

TEST(LcvRender, WritesSnapshotsAndRejectsBadInput) {
  const fs::path dir = fs::path(::testing::TempDir()) / ("lcv_render_cli_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const slam::Map map = KnownMap();
  mapping::WriteMap(map, (dir / "map.json").string());
  const std::string lcv = std::string(LCV_BINARY) + " render " + (dir / "map.json").string();
  EXPECT_EQ(RunCommand(std::string(LCV_BINARY) + " render --help").substr(0, 2), "0:");
  ASSERT_EQ(RunCommand(lcv + " --out " + (dir / "a.png").string() + " --view top --legend 2>&1").substr(0, 2), "0:");
  ASSERT_EQ(RunCommand(lcv + " --out " + (dir / "b.png").string() + " --view top --legend 2>&1").substr(0, 2), "0:");
  EXPECT_EQ(mapping::ReadFileBytes((dir / "a.png").string()), mapping::ReadFileBytes((dir / "b.png").string()));
  const std::string kf = std::to_string(map.keyframes.begin()->first);
  EXPECT_EQ(RunCommand(lcv + " --out " + (dir / "k.png").string() + " --view keyframe:" + kf + " 2>&1").substr(0, 2), "0:");
  const std::string missing = RunCommand(lcv + " --out " + (dir / "k.png").string() + " --view keyframe:999999 2>&1");
  EXPECT_EQ(missing.substr(0, 2), "1:");
  EXPECT_NE(missing.find("999999"), std::string::npos) << missing;
  // Risk CSV: good and bad.
  mapping::WriteFileAtomically((dir / "risk.csv").string(), "line_id,risk\n" + std::to_string(map.lines.begin()->first) + ",0.9\n");
  EXPECT_EQ(RunCommand(lcv + " --out " + (dir / "r.png").string() + " --color-by risk --risk " + (dir / "risk.csv").string() + " 2>&1").substr(0, 2), "0:");
  // An audit report naming its risk files relative to its own folder.
  fs::create_directories(dir / "audit");
  mapping::WriteFileAtomically((dir / "audit" / "report.json").string(),
                               R"({"format": "lcv-audit", "attacks": [{"name": "density", "risk_file": "../risk.csv"}]})");
  EXPECT_EQ(RunCommand(lcv + " --out " + (dir / "r2.png").string() + " --color-by risk --attack density --risk " + (dir / "audit" / "report.json").string() + " 2>&1").substr(0, 2), "0:");
  const std::string no_attack = RunCommand(lcv + " --out " + (dir / "r2.png").string() + " --color-by risk --attack nope --risk " + (dir / "audit" / "report.json").string() + " 2>&1");
  EXPECT_EQ(no_attack.substr(0, 2), "1:");
  EXPECT_NE(no_attack.find("no attack named 'nope'"), std::string::npos) << no_attack;
  mapping::WriteFileAtomically((dir / "bad.csv").string(), "line_id,risk\n12,1.7\n");
  const std::string bad = RunCommand(lcv + " --out " + (dir / "r.png").string() + " --color-by risk --risk " + (dir / "bad.csv").string() + " 2>&1");
  EXPECT_EQ(bad.substr(0, 2), "1:");
  EXPECT_NE(bad.find("bad.csv: line 2"), std::string::npos) << bad;
  EXPECT_EQ(RunCommand(lcv + " --out x.png --view sideways 2>&1").substr(0, 2), "2:");
  // Orbit as numbered PNGs.
  EXPECT_EQ(RunCommand(lcv + " --out " + (dir / "orbit.png").string() + " --view orbit --frames 3 --size 160x90 2>&1").substr(0, 2), "0:");
  EXPECT_TRUE(fs::exists(dir / "orbit_002.png"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace lcv::render
