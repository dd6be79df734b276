// `lcv map transform --sim3-align-to` through the built binary.
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <vector>

#include <gtest/gtest.h>

#include "mapping/io/map_file.h"
#include "mapping/io/trajectory.h"
#include "mapping/synthetic_map.h"
#include "slam/geometry/sim3.h"
#include "tests/support/cli_run.h"

namespace lcv {
namespace {

namespace fs = std::filesystem;

TEST(MapTransformCli, MovesTheMapOntoTheGroundTruthAndReportsBadInput) {
  const fs::path dir = fs::temp_directory_path() / ("lcv_map_transform_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  auto path = [&](const std::string& name) { return (dir / name).string(); };
  mapping::SyntheticMapOptions o;
  o.num_points = 200;
  o.num_keyframes = 8;
  o.seed = 4;
  slam::Map map = mapping::MakeSyntheticPointMap(o);
  int k = 0;
  for (auto& [id, kf] : map.keyframes) kf.timestamp = 0.5 * k++;
  mapping::WriteMap(map, path("map.lcmap"));
  // Ground truth: the keyframes seen through a known similarity.
  const slam::Sim3d gt_from_map(0.25, Eigen::Quaterniond(Eigen::AngleAxisd(1.0, Eigen::Vector3d(0, 0.6, 0.8))),
                                Eigen::Vector3d(10, -5, 2));
  mapping::Trajectory gt;
  for (const auto& [id, kf] : map.keyframes) {
    gt.poses.push_back({kf.timestamp, slam::TransformPose(gt_from_map, kf.cam_from_world)});
  }
  mapping::WriteTrajectory(gt, path("gt.txt"), mapping::TrajectoryFormat::kTum);

  const test::CliResult r = test::RunLcv(
      "map transform " + path("map.lcmap") + " " + path("moved.json") + " --sim3-align-to " + path("gt.txt"),
      dir.string());
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("8 keyframes matched"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("scale 0.25"), std::string::npos) << r.out;
  const slam::Map moved = mapping::ReadMap(path("moved.json"));
  ASSERT_EQ(moved.points.size(), map.points.size());
  for (const auto& [id, p] : moved.points) {
    EXPECT_LT((p.position - gt_from_map * map.points.at(id).position).norm(), 1e-6) << id;
  }
  EXPECT_NE(moved.description.find("--sim3-align-to"), std::string::npos);

  // --ground-truth-poses: keyframes on the ground truth, points refined on them (the synthetic
  // points are true, so they stay near the truth: keypoint noise only).
  const test::CliResult on_gt = test::RunLcv("map transform " + path("map.lcmap") + " " +
                                                 path("gt_poses.json") + " --sim3-align-to " +
                                                 path("gt.txt") + " --ground-truth-poses",
                                             dir.string());
  ASSERT_EQ(on_gt.exit_code, 0) << on_gt.out << on_gt.err;
  EXPECT_NE(on_gt.out.find("ground-truth poses: 8 keyframes"), std::string::npos) << on_gt.out;
  EXPECT_NE(on_gt.out.find("camera rotation against the ground truth 0.000 deg"),
            std::string::npos) << on_gt.out;
  const slam::Map refined = mapping::ReadMap(path("gt_poses.json"));
  size_t i = 0;
  for (const auto& [id, kf] : refined.keyframes) {
    EXPECT_LT((kf.cam_from_world.Center() - gt.poses[i++].cam_from_world.Center()).norm(), 1e-9);
  }
  // Far points triangulate poorly from 8 keyframes 1 m apart (1 px noise): the median.
  ASSERT_GT(refined.points.size(), map.points.size() / 2);
  std::vector<double> errors;
  for (const auto& [id, p] : refined.points) {
    errors.push_back((p.position - gt_from_map * map.points.at(id).position).norm() /
                     gt_from_map.scale);
  }
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  EXPECT_LT(errors[errors.size() / 2], 0.6) << "median point error, metres of the map";
  EXPECT_NE(refined.description.find("--ground-truth-poses"), std::string::npos);

  // Ground truth at other times: nothing matches; exit 1 naming the map and the reason.
  for (auto& p : gt.poses) p.timestamp += 100.0;
  mapping::WriteTrajectory(gt, path("late.txt"), mapping::TrajectoryFormat::kTum);
  const test::CliResult late = test::RunLcv(
      "map transform " + path("map.lcmap") + " " + path("x.lcmap") + " --sim3-align-to " + path("late.txt"),
      dir.string());
  EXPECT_EQ(late.exit_code, 1);
  EXPECT_NE(late.err.find("0 keyframes matched"), std::string::npos) << late.err;
  EXPECT_FALSE(fs::exists(path("x.lcmap")));
  EXPECT_EQ(test::RunLcv("map transform " + path("map.lcmap") + " " + path("x.lcmap"), dir.string()).exit_code, 2)
      << "--sim3-align-to is required";
  fs::remove_all(dir);
}

}  // namespace
}  // namespace lcv
