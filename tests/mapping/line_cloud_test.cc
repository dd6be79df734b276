#include "mapping/line_cloud.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>
#include <set>

#include "mapping/io/map_file.h"
#include "mapping/synthetic_map.h"

namespace lcv::mapping {
namespace {

slam::Map PointMap(std::uint64_t seed = 1, int num_points = 500) {
  SyntheticMapOptions o;
  o.num_points = num_points;
  o.num_keyframes = 10;
  o.seed = seed;
  return MakeSyntheticPointMap(o);
}

TEST(LineCloud, EveryPointBecomesALineThroughItWithTheSameId) {
  const slam::Map points = PointMap();
  const slam::Map lines = ConvertToLineCloud(points, LineCloudOptions{42});
  EXPECT_TRUE(slam::IsPublishedLineCloud(lines));
  EXPECT_TRUE(lines.keyframes.empty());
  EXPECT_TRUE(lines.points.empty());
  ASSERT_EQ(lines.lines.size(), points.points.size());
  EXPECT_EQ(lines.cameras.size(), points.cameras.size());
  for (const auto& [id, point] : points.points) {
    ASSERT_TRUE(lines.lines.count(id));
    const slam::LineLandmark& line = lines.lines.at(id);
    EXPECT_EQ(line.id, id);
    EXPECT_NEAR(line.line.direction.norm(), 1.0, 1e-15);
    // The hidden point is on the line...
    EXPECT_LT(line.line.Distance(point.position), 1e-12 * (1.0 + point.position.norm()));
    // ...but not at its anchor.
    EXPECT_GT((line.line.anchor - point.position).norm(), 1e-6);
    EXPECT_EQ(line.descriptor, point.descriptor);
    EXPECT_FALSE(line.restored_point.has_value());
    EXPECT_TRUE(line.observations.empty());
  }
  EXPECT_NO_THROW(ValidateMap(lines, "converted"));
}

TEST(LineCloud, AnchorIsAFunctionOfTheLineAlone) {
  // Two maps with one point each, the second point moved along the line of the first: same
  // seed, same (only) draw, so the same direction; the anchors must coincide.
  slam::Map a = PointMap(3, 1);
  const slam::Id id = a.points.begin()->first;
  const slam::Map line_a = ConvertToLineCloud(a, LineCloudOptions{9});
  const Eigen::Vector3d d = line_a.lines.at(id).line.direction;
  for (double shift : {-20.0, -0.37, 0.5, 13.0}) {
    slam::Map b = a;
    b.points.at(id).position += shift * d;
    const slam::Map line_b = ConvertToLineCloud(b, LineCloudOptions{9});
    EXPECT_EQ(line_b.lines.at(id).line.direction, d);
    EXPECT_LT((line_b.lines.at(id).line.anchor - line_a.lines.at(id).line.anchor).norm(), 1e-12)
        << "shift " << shift;
  }
  // The documented rule: the foot of the perpendicular from the origin.
  const slam::Map lines = ConvertToLineCloud(PointMap(), LineCloudOptions{1});
  for (const auto& [lid, line] : lines.lines) {
    EXPECT_LT(std::abs(line.line.anchor.dot(line.line.direction)), 1e-12);
  }
}

TEST(LineCloud, DirectionsAreUniformAndIndependentOfTheScene) {
  const slam::Map points = PointMap(5, 3000);
  const slam::Map lines = ConvertToLineCloud(points, LineCloudOptions{77});
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second_moment = Eigen::Matrix3d::Zero();
  for (const auto& [id, line] : lines.lines) {
    mean += line.line.direction;
    second_moment += line.line.direction * line.line.direction.transpose();
  }
  const double n = static_cast<double>(lines.lines.size());
  mean /= n;
  second_moment /= n;
  // Uniform on the sphere: E[d] = 0, E[d d^T] = I/3 (std of each mean component 1/sqrt(3n)).
  EXPECT_LT(mean.norm(), 4.0 / std::sqrt(3.0 * n));
  EXPECT_LT((second_moment - Eigen::Matrix3d::Identity() / 3.0).cwiseAbs().maxCoeff(), 0.03);
  // Another scene with the same number of points and seed: the same directions.
  const slam::Map other = ConvertToLineCloud(PointMap(6, 3000), LineCloudOptions{77});
  auto it = other.lines.begin();
  for (const auto& [id, line] : lines.lines) {
    EXPECT_EQ(line.line.direction, (it++)->second.line.direction);
  }
  // Another seed: other directions.
  const slam::Map reseeded = ConvertToLineCloud(points, LineCloudOptions{78});
  int same = 0;
  for (const auto& [id, line] : lines.lines) {
    same += line.line.direction == reseeded.lines.at(id).line.direction;
  }
  EXPECT_EQ(same, 0);
}

LineCloudOptions CovarianceRule(std::uint64_t seed) {
  LineCloudOptions o;
  o.seed = seed;
  o.information = LineInformationRule::kPointCovariance;
  return o;
}

TEST(LineCloud, InformationFromThePointCovariance) {
  const slam::Map points = PointMap(8, 200);
  const slam::Map lines = ConvertToLineCloud(points, CovarianceRule(4));
  for (const auto& [id, point] : points.points) {
    const slam::LineLandmark& line = lines.lines.at(id);
    const Eigen::Vector3d& d = line.line.direction;
    const Eigen::Matrix3d& omega = line.information;
    EXPECT_LT((omega * d).norm(), 1e-9 * omega.norm());
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(omega);
    EXPECT_GT(eig.eigenvalues()(1), 0.0);  // rank 2
    // Omega is the inverse of P Sigma P on the plane orthogonal to d.
    const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - d * d.transpose();
    const Eigen::Matrix3d product = omega * (P * point.covariance * P);
    EXPECT_LT((product - P).norm(), 1e-6) << "point " << id;
  }
  // Isotropic covariance sigma^2 I gives (I - d d^T) / sigma^2.
  slam::Map single = PointMap(2, 1);
  single.points.begin()->second.covariance = 0.25 * Eigen::Matrix3d::Identity();
  const slam::Map line = ConvertToLineCloud(single, CovarianceRule(0));
  const slam::LineLandmark& l = line.lines.begin()->second;
  const Eigen::Matrix3d expected =
      (Eigen::Matrix3d::Identity() - l.line.direction * l.line.direction.transpose()) / 0.25;
  EXPECT_LT((l.information - expected).norm(), 1e-12);
}

TEST(LineCloud, DefaultInformationIsAFunctionOfThePublishedLineAlone) {
  // The point slides along its line and its covariance changes: the published Omega_L must not.
  slam::Map a = PointMap(3, 1);
  const slam::Id id = a.points.begin()->first;
  const slam::Map line_a = ConvertToLineCloud(a, LineCloudOptions{9});
  const slam::LineLandmark& la = line_a.lines.at(id);
  for (double shift : {-3.0, -0.37, 0.5, 2.0}) {
    slam::Map b = a;
    b.points.at(id).position += shift * la.line.direction;
    b.points.at(id).covariance *= (1.0 + shift * shift);
    const slam::Map line_b = ConvertToLineCloud(b, LineCloudOptions{9});
    EXPECT_LT((line_b.lines.at(id).information - la.information).norm(),
              1e-9 * la.information.norm())
        << "shift " << shift;
  }
  // On a whole map: rank 2 with d in the null space, and what ProxyLineInformation computes from
  // the published cloud alone.
  const slam::Map lines = ConvertToLineCloud(PointMap(8, 300), LineCloudOptions{4});
  const double floor = ProxyDistanceFloor(lines);
  for (const auto& [lid, line] : lines.lines) {
    const Eigen::Matrix3d& omega = line.information;
    EXPECT_LT((omega * line.line.direction).norm(), 1e-9 * omega.norm());
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(omega);
    EXPECT_GT(eig.eigenvalues()(1), 0.0);
    EXPECT_LT((omega - ProxyLineInformation(lines, line, floor)).norm(), 1e-12 * omega.norm());
  }
}

// One keyframe at the origin looking down +z, the line y = 0, z = 10 along x: the proxy point is
// (0, 0, 10), the ray is z, so across the line y has one pixel's information at 10 m plus the
// prior, and z (along the ray) the prior alone.
TEST(LineCloud, ProxyInformationKnownAnswer) {
  slam::Map map;
  slam::CameraParams camera;
  camera.cols = 640;
  camera.rows = 360;
  camera.fx = camera.fy = 400.0;
  camera.cx = 319.5;
  camera.cy = 179.5;
  map.cameras[0] = camera;
  slam::ServerKeyframe kf;
  kf.id = 1;
  kf.camera_id = 0;
  kf.line_ids = {2};
  map.server_keyframes[1] = kf;
  slam::LineLandmark line;
  line.id = 2;
  line.line = slam::Line3d(Eigen::Vector3d(0, 0, 10), Eigen::Vector3d::UnitX());
  line.server_keyframe_ids = {1};
  map.lines[2] = line;
  EXPECT_DOUBLE_EQ(ProxyDistanceFloor(map), kProxyDistanceFloor * 10.0);
  SetProxyInformation(&map);
  const double pixel = 10.0 / 400.0;  // one pixel at 10 m
  Eigen::Matrix3d expected = Eigen::Matrix3d::Zero();
  expected(1, 1) = 1.0 / (pixel * pixel) + 1.0 / 100.0;
  expected(2, 2) = 1.0 / 100.0;
  EXPECT_LT((map.lines.at(2).information - expected).norm(), 1e-9 * expected.norm());
  // A second keyframe 2 m to the side: the ray directions differ, z gains information.
  slam::ServerKeyframe side = kf;
  side.id = 3;
  side.cam_from_world.translation = Eigen::Vector3d(0, -2, 0);  // centre (0, 2, 0)
  map.server_keyframes[3] = side;
  map.lines.at(2).server_keyframe_ids = {1, 3};
  SetProxyInformation(&map);
  EXPECT_GT(map.lines.at(2).information(2, 2), 10.0 * expected(2, 2));
}

TEST(LineCloud, RepublishingReplacesCovarianceInformation) {
  // A line cloud published with eq. (1) of the points' covariances and converted again (it has
  // no points, only lines) comes out with the default rule's information, the same as a direct
  // default conversion.
  const slam::Map points = PointMap(12, 200);
  const slam::Map leaky = ConvertToLineCloud(points, CovarianceRule(5));
  const slam::Map republished = ConvertToLineCloud(leaky, LineCloudOptions{5});
  const slam::Map direct = ConvertToLineCloud(points, LineCloudOptions{5});
  int changed = 0;
  for (const auto& [id, line] : republished.lines) {
    EXPECT_LT((line.information - direct.lines.at(id).information).norm(),
              1e-9 * line.information.norm());
    changed += (line.information - leaky.lines.at(id).information).norm() >
               1e-6 * line.information.norm();
  }
  EXPECT_EQ(changed, static_cast<int>(republished.lines.size()));
}

TEST(LineCloud, LinesNoKeyframeSeesGetOnePixelAtTheFloorDistance) {
  slam::Map lines = ConvertToLineCloud(PointMap(13, 50), LineCloudOptions{1});
  const slam::Id lonely = lines.lines.begin()->first;
  lines.lines.at(lonely).server_keyframe_ids.clear();
  for (auto& [kid, kf] : lines.server_keyframes) {
    kf.line_ids.erase(std::remove(kf.line_ids.begin(), kf.line_ids.end(), lonely),
                      kf.line_ids.end());
  }
  SetProxyInformation(&lines);
  const double sigma =
      ProxyDistanceFloor(lines) * slam::PixelAngle(lines.cameras.begin()->second);
  const Eigen::Vector3d d = lines.lines.at(lonely).line.direction;
  const Eigen::Matrix3d expected =
      (Eigen::Matrix3d::Identity() - d * d.transpose()) * (1.0 / (sigma * sigma) + 1.0 /
      std::pow(ProxyDistanceFloor(lines), 2));
  EXPECT_LT((lines.lines.at(lonely).information - expected).norm(), 1e-9 * expected.norm());
}

TEST(LineCloud, KeyframesBecomeServerKeyframesWithVisibilityBothWays) {
  const slam::Map points = PointMap(9, 300);
  const slam::Map lines = ConvertToLineCloud(points, LineCloudOptions{2});
  ASSERT_EQ(lines.server_keyframes.size(), points.keyframes.size());
  for (const auto& [id, kf] : points.keyframes) {
    const slam::ServerKeyframe& server = lines.server_keyframes.at(id);
    EXPECT_EQ(server.camera_id, kf.camera_id);
    EXPECT_EQ(server.timestamp, kf.timestamp);
    EXPECT_EQ(server.cam_from_world.rotation.coeffs(), kf.cam_from_world.rotation.coeffs());
    EXPECT_EQ(server.cam_from_world.translation, kf.cam_from_world.translation);
    EXPECT_EQ(server.line_ids.size(), kf.keypoints.size());
    EXPECT_TRUE(std::is_sorted(server.line_ids.begin(), server.line_ids.end()));
    for (slam::Id line_id : server.line_ids) {
      const auto& seen_by = lines.lines.at(line_id).server_keyframe_ids;
      EXPECT_TRUE(std::binary_search(seen_by.begin(), seen_by.end(), id));
    }
  }
  for (const auto& [id, point] : points.points) {
    std::vector<slam::Id> expected;
    for (const auto& obs : point.observations) expected.push_back(obs.keyframe_id);
    std::sort(expected.begin(), expected.end());
    EXPECT_EQ(lines.lines.at(id).server_keyframe_ids, expected);
  }
}

TEST(LineCloud, ExistingLinesLoseTheirRestoredPointsAndObservations) {
  slam::Map map = PointMap(10, 50);
  const slam::Id line_id = map.NextFreeId();
  slam::LineLandmark line;
  line.id = line_id;
  const Eigen::Vector3d restored(1.0, -2.0, 15.0);
  line.line = slam::Line3d(restored, Eigen::Vector3d(0.0, 0.6, 0.8));  // anchored at X'!
  line.information = slam::LineInformation(line.line.direction, Eigen::Matrix3d::Identity());
  line.restored_point = restored;
  const slam::Id observer = map.keyframes.begin()->first;
  line.observations = {{observer, 0}};
  map.lines[line_id] = line;
  const slam::Map out = ConvertToLineCloud(map, LineCloudOptions{1});
  EXPECT_TRUE(slam::IsPublishedLineCloud(out));
  const slam::LineLandmark& kept = out.lines.at(line_id);
  EXPECT_FALSE(kept.restored_point.has_value());
  EXPECT_TRUE(kept.observations.empty());
  EXPECT_EQ(kept.line.direction, line.line.direction);
  EXPECT_LT(kept.line.Distance(restored), 1e-12);
  EXPECT_GT((kept.line.anchor - restored).norm(), 1.0);  // re-anchored
  EXPECT_EQ(kept.server_keyframe_ids, std::vector<slam::Id>{observer});
  const auto& ids = out.server_keyframes.at(observer).line_ids;
  EXPECT_TRUE(std::binary_search(ids.begin(), ids.end(), line_id));
}

// Every floating-point number of a document, recursively (integers are ids and sizes).
void CollectNumbers(const nlohmann::json& j, std::vector<double>* out) {
  if (j.is_number_float()) out->push_back(j.get<double>());
  if (j.is_array() || j.is_object()) {
    for (const auto& child : j) CollectNumbers(child, out);
  }
}

TEST(LineCloud, PublishedFileContainsNoHiddenCoordinate) {
  const slam::Map points = PointMap(12, 400);
  const slam::Map lines = ConvertToLineCloud(points, LineCloudOptions{31});
  std::set<double> hidden;
  for (const auto& [id, point] : points.points) {
    for (int a = 0; a < 3; ++a) hidden.insert(point.position(a));
  }
  for (const auto& [id, kf] : points.keyframes) {
    for (const auto& kp : kf.keypoints) {
      hidden.insert(kp.x);
      hidden.insert(kp.y);
    }
  }
  // Text encoding: no number equals a hidden coordinate or keypoint coordinate.
  const std::string text = SerializeMap(lines, MapEncoding::kJson);
  std::vector<double> numbers;
  CollectNumbers(nlohmann::json::parse(text), &numbers);
  ASSERT_GT(numbers.size(), 400u * 15);
  for (double v : numbers) {
    // Plane coordinates shared by many points (x = -6, y = 1.6) are scene constants, not
    // per-point secrets; none of them appears either.
    EXPECT_EQ(hidden.count(v), 0u) << "value " << v << " is a hidden coordinate";
  }
  // Binary encoding: no hidden coordinate appears as a big-endian float64 or float32.
  const std::string pack = SerializeMap(lines, MapEncoding::kMessagePack);
  for (const auto& [id, point] : points.points) {
    for (int a = 0; a < 3; ++a) {
      const double value = point.position(a);
      std::uint64_t bits64;
      std::memcpy(&bits64, &value, 8);
      std::string pattern64;
      for (int b = 7; b >= 0; --b) pattern64 += static_cast<char>((bits64 >> (8 * b)) & 0xff);
      EXPECT_EQ(pack.find(pattern64), std::string::npos);
      const float single = static_cast<float>(value);
      std::uint32_t bits32;
      std::memcpy(&bits32, &single, 4);
      std::string pattern32;
      for (int b = 3; b >= 0; --b) pattern32 += static_cast<char>((bits32 >> (8 * b)) & 0xff);
      EXPECT_EQ(pack.find(pattern32), std::string::npos);
    }
  }
}

TEST(LineCloud, DeterministicForOneSeed) {
  const slam::Map points = PointMap(13, 100);
  EXPECT_EQ(
      SerializeMap(ConvertToLineCloud(points, LineCloudOptions{5}), MapEncoding::kMessagePack),
      SerializeMap(ConvertToLineCloud(points, LineCloudOptions{5}), MapEncoding::kMessagePack));
}

}  // namespace
}  // namespace lcv::mapping

namespace lcv::mapping {
namespace {

TEST(LineCloud, CoincidentPointsBecomeOneLine) {
  slam::Map points = PointMap(3, 400);
  // 20 points published twice (a COLMAP model's near-duplicates), 10 micrometres apart.
  slam::Id next = points.NextFreeId();
  std::vector<std::pair<slam::Id, slam::Id>> twins;
  int added = 0;
  for (const auto& [id, point] : std::map<slam::Id, slam::PointLandmark>(points.points)) {
    if (added++ == 20) break;
    slam::PointLandmark twin = point;
    twin.id = next++;
    twin.position += Eigen::Vector3d(1e-5, 0, 0);
    points.points[twin.id] = twin;
    twins.emplace_back(id, twin.id);
  }
  LineCloudReport report;
  const slam::Map lines = ConvertToLineCloud(points, LineCloudOptions{7}, &report);
  EXPECT_EQ(report.coincident_groups, 20);
  EXPECT_EQ(report.points_merged_away, 20);
  EXPECT_EQ(lines.lines.size(), points.points.size() - 20);
  for (const auto& [kept, twin] : twins) {
    ASSERT_TRUE(lines.lines.count(kept));
    EXPECT_FALSE(lines.lines.count(twin));
    // The kept line passes through both (their mean) and is seen by both's keyframes.
    EXPECT_LT(lines.lines.at(kept).line.Distance(points.points.at(kept).position), 1e-4);
  }
  // Without the merge, the twins' lines would cross within micrometres.
  LineCloudOptions off{7};
  off.coincident_distance = 0.0;
  const slam::Map unmerged = ConvertToLineCloud(points, off);
  EXPECT_EQ(unmerged.lines.size(), points.points.size());
  const auto crossing = slam::ClosestPointsBetweenLines(unmerged.lines.at(twins[0].first).line,
                                                        unmerged.lines.at(twins[0].second).line);
  ASSERT_TRUE(crossing);
  EXPECT_LT(crossing->distance, 1e-4);
  EXPECT_NO_THROW(ValidateMap(lines, "lines"));
}

TEST(LineCloud, FarPointsDoNotWidenTheCoincidentDistance) {
  // An equirectangular map triangulates a few points near the horizon, kilometres away. The
  // default merge distance must stay at the scale of the scene: distinct points stay lines.
  slam::Map points = PointMap(4, 400);
  slam::Id next = points.NextFreeId();
  const slam::PointLandmark& some = points.points.begin()->second;
  for (int k = 0; k < 5; ++k) {
    slam::PointLandmark far = some;
    far.id = next++;
    far.position = Eigen::Vector3d(5000.0 * (k + 1), -3000.0 * k, 800.0);
    points.points[far.id] = far;
  }
  LineCloudReport report;
  const slam::Map lines = ConvertToLineCloud(points, LineCloudOptions{7}, &report);
  EXPECT_EQ(report.points_merged_away, 0);
  EXPECT_EQ(lines.lines.size(), points.points.size());
}

}  // namespace
}  // namespace lcv::mapping
