#include "mapping/map_merge.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mapping/io/map_file.h"
#include "mapping/line_cloud.h"
#include "mapping/synthetic_map.h"
#include "privacy/map_alignment.h"
#include "slam/geometry/so3.h"

namespace lcv::mapping {
namespace {

using slam::Id;
using slam::Map;
using slam::Sim3d;

SyntheticMapOptions SceneOptions(std::uint64_t seed) {
  SyntheticMapOptions o;
  o.num_points = 1500;
  o.num_keyframes = 30;
  o.max_depth_m = 25.0;
  o.seed = seed;
  return o;
}

// Ids shifted by offset (an independent session numbers its own entities).
Map Renumbered(const Map& map, Id offset) {
  Map out;
  out.description = map.description;
  for (const auto& [id, camera] : map.cameras) out.cameras[id + offset] = camera;
  for (const auto& [id, kf] : map.keyframes) {
    slam::Keyframe k = kf;
    k.id += offset;
    k.camera_id += offset;
    out.keyframes[k.id] = k;
  }
  for (const auto& [id, point] : map.points) {
    slam::PointLandmark p = point;
    p.id += offset;
    for (auto& o : p.observations) o.keyframe_id += offset;
    out.points[p.id] = p;
  }
  return out;
}

// The keyframes [first, last] of a point map and the points they see (>= 2 of them).
Map Part(const Map& map, int first, int last) {
  Map out;
  out.cameras = map.cameras;
  std::set<Id> kept;
  int index = 0;
  for (const auto& [id, kf] : map.keyframes) {
    if (index >= first && index <= last) {
      out.keyframes[id] = kf;
      kept.insert(id);
    }
    ++index;
  }
  for (const auto& [id, point] : map.points) {
    slam::PointLandmark p = point;
    p.observations.clear();
    for (const auto& o : point.observations) {
      if (kept.count(o.keyframe_id)) p.observations.push_back(o);
    }
    if (p.observations.size() >= 2) out.points[id] = p;
  }
  return out;
}

void AddPointNoise(double sigma_m, std::uint64_t seed, Map* map) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma_m);
  for (auto& [id, p] : map->points) p.position += Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
}

Sim3d SomeSimilarity() {
  return Sim3d(1.7, slam::ExpSO3(Eigen::Vector3d(0.2, 0.5, -0.3)), Eigen::Vector3d(4, -2, 9));
}

double RotationErrorDeg(const Sim3d& a, const Sim3d& b) {
  return slam::AngularDistance(a.rotation, b.rotation) * 180.0 / M_PI;
}

// Lines of `map` passing within radius of p with a descriptor within 50 bits of d.
int LinesThrough(const Map& map, const Eigen::Vector3d& p, const slam::OrbDescriptor& d,
                 double radius) {
  int count = 0;
  for (const auto& [id, line] : map.lines) {
    if (line.descriptor && slam::HammingDistance(*line.descriptor, d) <= 50 &&
        line.line.Distance(p) <= radius) {
      ++count;
    }
  }
  return count;
}

double KeyframeError(const Map& merged, const Map& truth_session, Id offset) {
  double sum_sq = 0.0;
  int n = 0;
  for (const auto& [id, kf] : truth_session.keyframes) {
    // Merged server keyframes keep the upload's order; matched by timestamp.
    for (const auto& [sid, s] : merged.server_keyframes) {
      if (sid < offset || s.timestamp != kf.timestamp) continue;
      sum_sq += (s.cam_from_world.Center() - kf.cam_from_world.Center()).squaredNorm();
      ++n;
    }
  }
  return n ? std::sqrt(sum_sq / n) : 1e9;
}

// An upload in another unit than the base (a monocular client's unit is about its first scene
// depth; a base in millimetres is ~1e4 of those). The scale range used to stop at 1e3.
TEST(MapMerge, RegistersAnUploadInAnotherUnit) {
  const Map scene = MakeSyntheticPointMap(SceneOptions(1));
  const Map base = ConvertToLineCloud(scene, LineCloudOptions{1});
  Map session = Part(scene, 8, 24);
  AddPointNoise(0.01, 3, &session);
  const Sim3d some = SomeSimilarity();
  const Sim3d upload_from_base(2e-4, some.rotation, 2e-4 * some.translation);
  const Map upload = ConvertToLineCloud(
      privacy::TransformMap(Renumbered(session, 100000), upload_from_base), LineCloudOptions{2});
  MapMerger merger(base, MapMergeOptions{});
  const UploadMergeResult result = merger.AddUpload(upload, "upload");
  ASSERT_TRUE(result.accepted) << result.reason;
  ASSERT_TRUE(result.base_from_upload);
  const Sim3d truth = upload_from_base.Inverse();
  EXPECT_LT(RotationErrorDeg(*result.base_from_upload, truth), 1.0);
  EXPECT_LT(std::abs(result.base_from_upload->scale / truth.scale - 1.0), 0.01);
}

TEST(MapMerge, RegistersATransformedUploadOfTheSamePlace) {
  const Map scene = MakeSyntheticPointMap(SceneOptions(1));
  const Map base = ConvertToLineCloud(scene, LineCloudOptions{1});
  Map session = Part(scene, 8, 24);
  AddPointNoise(0.01, 3, &session);
  const Sim3d upload_from_base = SomeSimilarity();
  const Map upload = ConvertToLineCloud(
      privacy::TransformMap(Renumbered(session, 100000), upload_from_base), LineCloudOptions{2});

  MapMergeOptions options;  // auto frame: ids differ, so it must register
  MapMerger merger(base, options);
  const UploadMergeResult result = merger.AddUpload(upload, "upload");
  ASSERT_TRUE(result.accepted) << result.reason;
  EXPECT_EQ(result.frame, "independent");
  ASSERT_TRUE(result.base_from_upload);
  const Sim3d truth = upload_from_base.Inverse();
  EXPECT_LT(RotationErrorDeg(*result.base_from_upload, truth), 1.0);
  EXPECT_LT(std::abs(result.base_from_upload->scale / truth.scale - 1.0), 0.01);
  EXPECT_GT(result.lines_merged, static_cast<int>(0.7 * upload.lines.size()));
  EXPECT_EQ(result.server_keyframes_added, static_cast<int>(upload.server_keyframes.size()));

  MapMergeReport report;
  const Map merged = merger.Finish(&report);
  EXPECT_NO_THROW(ValidateMap(merged, "merged"));
  EXPECT_TRUE(slam::IsPublishedLineCloud(merged));
  // Privacy rule: one published line per physical point of the upload.
  int repeated = 0;
  for (const auto& [id, point] : session.points) {
    repeated += LinesThrough(merged, point.position, *point.descriptor, 0.05) > 1;
  }
  EXPECT_EQ(repeated, 0);
  // Server keyframes land near their true poses.
  EXPECT_LT(KeyframeError(merged, session, base.NextFreeId()), 0.05);
}

// An upload published with eq. 1 of its points' covariances: the merged map does not pass that
// Omega_L on; every line's is the publishing rule's for the merged map.
TEST(MapMerge, MergedLinesFollowThePublishingInformationRule) {
  const Map scene = MakeSyntheticPointMap(SceneOptions(1));
  const Map base = ConvertToLineCloud(scene, LineCloudOptions{1});
  LineCloudOptions eq1;
  eq1.seed = 2;
  eq1.information = LineInformationRule::kPointCovariance;
  const Map upload = ConvertToLineCloud(
      privacy::TransformMap(Renumbered(Part(scene, 8, 24), 100000), SomeSimilarity()), eq1);
  MapMerger merger(base, MapMergeOptions{});
  ASSERT_TRUE(merger.AddUpload(upload, "upload").accepted);
  MapMergeReport report;
  const Map merged = merger.Finish(&report);
  const double floor = ProxyDistanceFloor(merged);
  for (const auto& [id, line] : merged.lines) {
    ASSERT_LT((line.information - ProxyLineInformation(merged, line, floor)).norm(),
              1e-9 * line.information.norm())
        << "line " << id;
  }
}

TEST(MapMerge, RejectsAnUploadOfAnotherPlace) {
  const Map scene = MakeSyntheticPointMap(SceneOptions(1));
  const Map base = ConvertToLineCloud(scene, LineCloudOptions{1});
  SyntheticMapOptions other_options = SceneOptions(77);
  other_options.street_half_width_m = 9.0;
  other_options.facade_height_m = 14.0;
  Map other = Renumbered(MakeSyntheticPointMap(other_options), 100000);
  // The worst case for the check: descriptors copied from the base, so every line has
  // descriptor matches and only the geometry can tell.
  auto source = scene.points.begin();
  for (auto& [id, p] : other.points) {
    p.descriptor = source->second.descriptor;
    if (++source == scene.points.end()) source = scene.points.begin();
  }
  const Map upload = ConvertToLineCloud(other, LineCloudOptions{5});
  MapMerger merger(base, MapMergeOptions{});
  const UploadMergeResult result = merger.AddUpload(upload, "other place");
  EXPECT_FALSE(result.accepted);
  EXPECT_NE(result.reason.find("registration failed"), std::string::npos) << result.reason;
  EXPECT_GT(result.registration_candidates, 100);
  MapMergeReport report;
  const Map merged = merger.Finish(&report);
  EXPECT_EQ(merged.lines.size(), base.lines.size());
  EXPECT_EQ(merged.server_keyframes.size(), base.server_keyframes.size());
  ASSERT_EQ(report.uploads.size(), 1u);
  EXPECT_FALSE(report.uploads[0].accepted);
}

TEST(MapMerge, SameFrameUploadJoinsAndGainsVisibility) {
  const Map scene = MakeSyntheticPointMap(SceneOptions(2));
  const Map base = ConvertToLineCloud(scene, LineCloudOptions{1});
  // A client relocalized in the base: two keyframes seeing 40 base lines (same ids and
  // descriptors) and 5 lines of its own (ids of its own numbering).
  Map upload;
  upload.cameras = base.cameras;
  std::vector<Id> seen;
  for (const auto& [id, line] : base.lines) {
    if (seen.size() == 40) break;
    upload.lines[id] = line;
    upload.lines[id].server_keyframe_ids.clear();
    seen.push_back(id);
  }
  std::mt19937_64 rng(4);
  for (int k = 0; k < 5; ++k) {
    slam::LineLandmark line;
    line.id = 900000 + k;
    line.line = slam::Line3d(Eigen::Vector3d(k, 1, 20), slam::UniformUnitVector(0.1 * k, 0.3));
    line.information = slam::LineInformation(line.line.direction, 1e-4 * Eigen::Matrix3d::Identity());
    slam::OrbDescriptor d;
    for (auto& byte : d) byte = static_cast<std::uint8_t>(rng());
    line.descriptor = d;
    upload.lines[line.id] = line;
  }
  for (int k = 0; k < 2; ++k) {
    slam::ServerKeyframe kf = std::next(base.server_keyframes.begin(), 3 + k)->second;
    kf.id = 800000 + k;
    kf.line_ids.clear();
    for (const auto& [id, line] : upload.lines) kf.line_ids.push_back(id);
    for (const auto& [id, line] : upload.lines) upload.lines[id].server_keyframe_ids.push_back(kf.id);
    upload.server_keyframes[kf.id] = kf;
  }
  MapMerger merger(base, MapMergeOptions{});
  const UploadMergeResult result = merger.AddUpload(upload, "client");
  ASSERT_TRUE(result.accepted) << result.reason;
  EXPECT_EQ(result.frame, "same");
  EXPECT_EQ(result.lines_merged, 40);
  EXPECT_EQ(result.lines_added, 5);
  EXPECT_EQ(result.server_keyframes_added, 2);
  MapMergeReport report;
  const Map merged = merger.Finish(&report);
  EXPECT_NO_THROW(ValidateMap(merged, "merged"));
  EXPECT_EQ(merged.lines.size(), base.lines.size() + 5);
  EXPECT_EQ(merged.server_keyframes.size(), base.server_keyframes.size() + 2);
  for (Id id : seen) {
    EXPECT_EQ(merged.lines.at(id).server_keyframe_ids.size(),
              base.lines.at(id).server_keyframe_ids.size() + 2);
  }
  for (int k = 0; k < 5; ++k) EXPECT_FALSE(merged.lines.count(900000 + k));  // fresh ids
}

TEST(MapMerge, DuplicateLinesOfOnePointArePublishedOnce) {
  const Map scene = MakeSyntheticPointMap(SceneOptions(3));
  Map base = ConvertToLineCloud(scene, LineCloudOptions{1});
  // The same 100 points published again as new lines (another direction, a millimetre off),
  // seen by the same keyframes: the merge must keep one line of each pair.
  Map upload;
  upload.cameras = base.cameras;
  upload.server_keyframes = base.server_keyframes;
  for (auto& [id, kf] : upload.server_keyframes) kf.line_ids.clear();
  int added = 0;
  for (const auto& [id, point] : scene.points) {
    if (added++ == 100) break;
    slam::LineLandmark line;
    line.id = id + 500000;  // its own numbering
    line.line.direction = slam::UniformUnitVector(0.37 * added / 100.0, 0.61);
    line.line.anchor = point.position + Eigen::Vector3d(0.001, 0, 0);
    line.information = slam::LineInformation(line.line.direction, point.covariance);
    line.descriptor = point.descriptor;
    for (const auto& o : point.observations) {
      line.server_keyframe_ids.push_back(o.keyframe_id);
      upload.server_keyframes.at(o.keyframe_id).line_ids.push_back(line.id);
    }
    upload.lines[line.id] = line;
  }
  MapMergeOptions options;
  options.frame = UploadFrame::kSame;  // same frame, ids of its own
  MapMerger merger(base, options);
  const UploadMergeResult result = merger.AddUpload(upload, "again");
  ASSERT_TRUE(result.accepted);
  MapMergeReport report;
  const Map merged = merger.Finish(&report);
  EXPECT_EQ(report.uploads[0].lines_dropped, 100);
  EXPECT_EQ(merged.lines.size(), base.lines.size());
  int repeated = 0;
  for (const auto& [id, point] : scene.points) {
    repeated += LinesThrough(merged, point.position, *point.descriptor, 0.01) > 1;
  }
  EXPECT_EQ(repeated, 0);
}

// Drift: an upload whose poses and points carry a smooth Sim(3) drift along the street (scale,
// yaw and translation growing with z) in another frame. After registration the server keyframes
// are off by the drift; the optimization on the virtual observations (gauge: the base) must at
// least halve their position error against the ground truth.
Map Drifted(const Map& map, double z_mid) {
  auto drift = [&](double z) {
    const double u = z - z_mid;
    return Sim3d(1.0 + 0.0006 * u, slam::ExpSO3(Eigen::Vector3d(0, 0.0004 * u, 0.0002 * u)),
                 Eigen::Vector3d(0.004 * u, 0.002 * u, 0.0));
  };
  Map out = map;
  for (auto& [id, kf] : out.keyframes) {
    kf.cam_from_world = slam::TransformPose(drift(kf.cam_from_world.Center().z()), kf.cam_from_world);
  }
  for (auto& [id, p] : out.points) {
    const Sim3d S = drift(p.position.z());
    p.position = S * p.position;
  }
  return out;
}

TEST(MapMerge, OptimizationHalvesTheDriftOfAnUpload) {
  const Map scene = MakeSyntheticPointMap(SceneOptions(4));
  const Map base = ConvertToLineCloud(scene, LineCloudOptions{1});
  const Map session = Part(scene, 6, 26);
  const Map drifted = Drifted(session, 16.0);
  const Sim3d upload_from_base = SomeSimilarity();
  const Map upload = ConvertToLineCloud(
      privacy::TransformMap(Renumbered(drifted, 100000), upload_from_base), LineCloudOptions{2});
  const Id first_new = base.NextFreeId();

  // 0: registration only; 1: optimized with Omega_vL propagated from Omega_L; 2: constant.
  double errors[3];
  MapMergeReport reports[3];
  for (int optimize = 0; optimize < 3; ++optimize) {
    MapMergeOptions options;
    options.optimize = optimize >= 1;
    options.optimization.propagate_information = optimize == 1;
    MapMerger merger(base, options);
    const UploadMergeResult result = merger.AddUpload(upload, "drifted");
    ASSERT_TRUE(result.accepted) << result.reason;
    const Map merged = merger.Finish(&reports[optimize]);
    EXPECT_NO_THROW(ValidateMap(merged, "merged"));
    errors[optimize] = KeyframeError(merged, session, first_new);
  }
  std::printf("keyframe RMSE after registration %.4f m, after optimization %.4f m "
              "(propagated Omega_vL), %.4f m (constant Omega_vL)\n",
              errors[0], errors[1], errors[2]);
  ASSERT_TRUE(reports[1].optimization);
  EXPECT_TRUE(reports[1].optimization->success);
  EXPECT_LT(reports[1].optimization->cost_after, reports[1].optimization->cost_before);
  EXPECT_GT(errors[0], 0.02);  // the drift is there after registration
  EXPECT_LT(errors[1], 0.5 * errors[0]);
  EXPECT_LT(errors[2], errors[0]);
}

}  // namespace
}  // namespace lcv::mapping
