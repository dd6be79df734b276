// `lcv slam` end to end through the built binary: help, usage and config errors, and a short
// KITTI run (skipped without the shared data) checking the output files.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mapping/io/map_file.h"
#include "mapping/io/trajectory.h"

namespace {

namespace fs = std::filesystem;

struct RunResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr
};

RunResult RunLcv(const std::string& arguments) {
  const std::string command = std::string(LCV_BINARY) + " " + arguments + " 2>&1";
  RunResult result;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return result;
  char buffer[4096];
  size_t n;
  while ((n = fread(buffer, 1, sizeof(buffer), pipe)) > 0) result.output.append(buffer, n);
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

fs::path TempDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("lcv_cmd_slam_test_" + name);
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

TEST(CmdSlamTest, HelpListsEveryOption) {
  const RunResult r = RunLcv("slam --help");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  for (const char* flag : {"--dataset", "--trajectory-out", "--config", "--frames", "--map-out",
                           "--stats-out", "--deterministic", "--background-nice",
                           "--tracking-rt-priority", "example:"}) {
    EXPECT_NE(r.output.find(flag), std::string::npos) << flag;
  }
}

TEST(CmdSlamTest, UsageErrors) {
  EXPECT_EQ(RunLcv("slam --trajectory-out x.txt").exit_code, 2);  // no --dataset
  EXPECT_EQ(RunLcv("slam --dataset d --trajectory-out x.txt --bogus").exit_code, 2);
  const RunResult r = RunLcv("slam --dataset d --trajectory-out x.txt --frames 5:1:0");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--frames"), std::string::npos) << r.output;
  const RunResult nice = RunLcv("slam --dataset d --trajectory-out x.txt --background-nice 20");
  EXPECT_EQ(nice.exit_code, 2) << nice.output;
  EXPECT_NE(nice.output.find("--background-nice"), std::string::npos) << nice.output;
  const RunResult rt = RunLcv("slam --dataset d --trajectory-out x.txt --tracking-rt-priority 100");
  EXPECT_EQ(rt.exit_code, 2) << rt.output;
  EXPECT_NE(rt.output.find("--tracking-rt-priority"), std::string::npos) << rt.output;
}

// The keyframe trajectory's default path (TRAJECTORY.keyframes.txt) is checked before the run,
// like every output given on the command line: here it is a directory.
TEST(CmdSlamTest, UnwritableDefaultKeyframesOutFailsBeforeTheRun) {
  const fs::path dir = TempDir("keyframes_out");
  fs::create_directories(dir / "t.txt.keyframes.txt");
  const RunResult r = RunLcv("slam --dataset " + (dir / "missing").string() +
                             " --trajectory-out " + (dir / "t.txt").string());
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("--keyframes-out"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("t.txt.keyframes.txt"), std::string::npos) << r.output;
}

TEST(CmdSlamTest, BadConfigNamesFileAndField) {
  const fs::path dir = TempDir("config");
  const std::string config = (dir / "bad.yaml").string();
  struct Case {
    const char* yaml;
    std::string expected;  // in the message
  };
  const Case cases[] = {
      {"Tracking:\n  min_tracked_inliers: 40\n  motion_radius: 3\n",
       config + ": Tracking.motion_radius: unknown setting"},
      {"Feature:\n  scale_factor: 0.5\n", "Feature.scale_factor: 0.5 is outside"},
      {"System:\n  background_nice: 25\n", "System.background_nice: 25 is outside"},
      {"Mapper:\n  x: 1\n", "Mapper: unknown section"},
      {"LineCloud:\n  close_loops: true\n  virtual_information: exact\n",
       "LineCloud.virtual_information: expected constant or derived"},
      {"LineCloud:\n  snapshot_server_keyframes: -1\n",
       "LineCloud.snapshot_server_keyframes: -1 is outside"},
  };
  for (const Case& c : cases) {
    {
      std::ofstream out(config);
      out << c.yaml;
    }
    const RunResult r = RunLcv("slam --dataset " + dir.string() + " --trajectory-out " +
                               (dir / "t.txt").string() + " --config " + config);
    EXPECT_EQ(r.exit_code, 1) << c.yaml << r.output;
    EXPECT_NE(r.output.find(c.expected), std::string::npos) << c.yaml << r.output;
  }
  fs::remove_all(dir);
}

TEST(CmdSlamTest, KittiStretchWritesTrajectoryMapAndStats) {
  const std::string kitti = std::string(LCV_SHARED_DIR) + "/data/kitti00";
  if (!fs::exists(kitti + "/image_0/000000.png")) {
    GTEST_SKIP() << "shared KITTI data absent: " << kitti;
  }
  const fs::path dir = TempDir("kitti");
  const std::string trajectory = (dir / "traj.txt").string();
  const std::string stats_path = (dir / "stats.json").string();
  const std::string map_path = (dir / "map.lcmap").string();
  const RunResult r = RunLcv("slam --dataset " + kitti + " --frames 0:30 --deterministic " +
                             "--num-features 1000 --trajectory-out " + trajectory +
                             " --stats-out " + stats_path + " --map-out " + map_path);
  ASSERT_EQ(r.exit_code, 0) << r.output;

  std::ifstream in(stats_path);
  const nlohmann::json stats = nlohmann::json::parse(in);
  EXPECT_EQ(stats.at("frames").get<int>(), 30);
  const int tracked = stats.at("tracked").get<int>();
  EXPECT_GE(tracked, 25);
  EXPECT_GE(stats.at("keyframes").get<int>(), 2);
  EXPECT_GT(stats.at("points").get<int>(), 100);
  for (const char* key : {"median", "mean", "p95"}) {
    EXPECT_GT(stats.at("tracking_ms").at(key).get<double>(), 0.0) << key;
  }
  EXPECT_EQ(stats.at("per_frame").size(), 30u);
  EXPECT_LT(stats.at("ape_sim3").at("rmse").get<double>(), 0.5);

  const auto traj = lcv::mapping::ReadTrajectory(trajectory, lcv::mapping::TrajectoryFormat::kTum);
  // The tracked frames, and the frames seen while initializing that were posed once the map
  // existed (at least the initialization's reference frame, the first keyframe).
  EXPECT_GT(static_cast<int>(traj.poses.size()), tracked);
  EXPECT_LE(static_cast<int>(traj.poses.size()),
            tracked + stats.at("initializing").get<int>());
  const auto keyframes =
      lcv::mapping::ReadTrajectory(trajectory + ".keyframes.txt", lcv::mapping::TrajectoryFormat::kTum);
  EXPECT_EQ(static_cast<int>(keyframes.poses.size()), stats.at("keyframes").get<int>());
  const lcv::slam::Map map = lcv::mapping::ReadMap(map_path);  // validates
  EXPECT_EQ(static_cast<int>(map.points.size()), stats.at("points").get<int>());
  fs::remove_all(dir);
}

// A camera lost for good whose new map never merges (KITTI 00 with a 5 s jump): the outputs
// hold the bigger map, and the other is written beside them in its own frame, so nothing the
// run mapped is dropped (docs/slam.md "Which segment the outputs hold").
TEST(CmdSlamTest, LostMapNeverMergedIsWrittenBesideTheOutputs) {
  const std::string kitti = std::string(LCV_SHARED_DIR) + "/data/kitti00";
  if (!fs::exists(kitti + "/image_0/000000.png")) {
    GTEST_SKIP() << "shared KITTI data absent: " << kitti;
  }
  const fs::path dir = TempDir("kitti_gap");
  const RunResult r = RunLcv("slam --dataset " + kitti + " --frames 0:60,110:135 --deterministic" +
                             " --trajectory-out " + (dir / "traj.txt").string() +
                             " --stats-out " + (dir / "stats.json").string() +
                             " --map-out " + (dir / "map.lcmap").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(dir / "stats.json");
  const nlohmann::json stats = nlohmann::json::parse(in);
  ASSERT_EQ(stats.at("maps_left_out").get<int>(), 1) << r.output;
  EXPECT_NE(r.output.find("traj.lost1.txt"), std::string::npos) << r.output;
  const auto kept = lcv::mapping::ReadTrajectory((dir / "traj.txt").string(),
                                                 lcv::mapping::TrajectoryFormat::kTum);
  const auto lost = lcv::mapping::ReadTrajectory((dir / "traj.lost1.txt").string(),
                                                 lcv::mapping::TrajectoryFormat::kTum);
  // Frames 0-59 before the jump (6 s at 10 fps), 110-134 after it.
  ASSERT_FALSE(kept.poses.empty());
  ASSERT_FALSE(lost.poses.empty());
  EXPECT_LT(kept.poses.back().timestamp, 6.5);
  EXPECT_GT(lost.poses.front().timestamp, 10.5);
  EXPECT_GT(kept.poses.size(), lost.poses.size());
  EXPECT_LE(static_cast<int>(kept.poses.size() + lost.poses.size()),
            stats.at("tracked").get<int>() + stats.at("initializing").get<int>());
  const lcv::slam::Map map = lcv::mapping::ReadMap((dir / "map.lcmap").string());
  const lcv::slam::Map lost_map = lcv::mapping::ReadMap((dir / "map.lost1.lcmap").string());
  EXPECT_EQ(static_cast<int>(map.keyframes.size()), stats.at("keyframes").get<int>());
  EXPECT_GE(lost_map.keyframes.size(), 2u);
  for (const auto& [id, kf] : lost_map.keyframes) EXPECT_EQ(map.keyframes.count(id), 0u);
  fs::remove_all(dir);
}

}  // namespace

namespace {

// Live mode through the binary (issue 14): a camera thread delivers the frames at the
// sequence's rate; whatever the machine's speed, every frame is either tracked (a result) or
// dropped, never queued, and the stats say which; the threads' lock statistics are written.
TEST(CmdSlamTest, RealtimeAccountsForEveryFrameAndWritesThreadStats) {
  const fs::path dir = TempDir("realtime");
  const int kFrames = 30;  // 3 s at the synthetic 10 Hz
  const RunResult synth = RunLcv("synth --scenario tracking --frames " + std::to_string(kFrames) +
                                 " --seed 2 --out " + (dir / "seq").string());
  ASSERT_EQ(synth.exit_code, 0) << synth.output;
  const RunResult r = RunLcv("slam --dataset " + (dir / "seq").string() + " --realtime" +
                             " --trajectory-out " + (dir / "t.txt").string() + " --stats-out " +
                             (dir / "s.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::ifstream in(dir / "s.json");
  const nlohmann::json stats = nlohmann::json::parse(in);
  EXPECT_TRUE(stats["live"].get<bool>());
  const int processed = stats["frames"].get<int>();
  const int dropped = stats["frames_dropped"].get<int>();
  EXPECT_EQ(processed + dropped, kFrames);
  EXPECT_EQ(static_cast<int>(stats["per_frame"].size()), processed);
  EXPECT_TRUE(stats.contains("keyframes_refused"));
  for (const char* key : {"median", "p90", "p95", "p99", "max"}) {
    EXPECT_TRUE(stats["tracking_ms"].contains(key)) << key;
  }
  for (const char* thread : {"tracking", "mapping", "loop_closing"}) {
    ASSERT_TRUE(stats["map_lock_ms"].contains(thread)) << thread;
    EXPECT_TRUE(stats["map_lock_ms"][thread].contains("max")) << thread;
    EXPECT_TRUE(stats["map_lock_ms"][thread].contains("p99")) << thread;
  }
  EXPECT_GT(stats["map_lock_ms"]["tracking"]["count"].get<int>(), 0);
  // The background threads ran below tracking (default --background-nice 5), unless the system
  // refused, which the stats then say.
  EXPECT_EQ(stats["background_nice"].get<int>(), 5);
  if (stats["thread_priority_error"].get<std::string>().empty()) {
    EXPECT_EQ(stats["thread_nice"]["mapping"].get<int>(),
              std::min(19, stats["thread_nice"]["tracking"].get<int>() + 5));
    EXPECT_EQ(stats["thread_nice"]["loop_closing"].get<int>(),
              stats["thread_nice"]["mapping"].get<int>());
  }
  // Tracking ran under SCHED_FIFO (default --tracking-rt-priority 10), or the refusal is said.
  if (stats["tracking_rt_priority"].get<int>() != 10) {
    EXPECT_EQ(stats["tracking_rt_priority"].get<int>(), 0);
    EXPECT_NE(stats["thread_priority_error"].get<std::string>(), "");
    EXPECT_NE(r.output.find("normal scheduling"), std::string::npos) << r.output;
  }
  // Where tracking's time went: per frame and per stage.
  for (const char* key : {"median", "p99", "max"}) {
    EXPECT_TRUE(stats["tracking_cpu_ms"].contains(key)) << key;
  }
  EXPECT_TRUE(stats.contains("preemptions"));
  for (const char* stage : {"handover", "initializer", "initialization_frames", "motion",
                            "recovery", "relocalization", "local_map", "keyframe_decision"}) {
    EXPECT_TRUE(stats["stages_ms"].contains(stage)) << stage;
    for (const auto& frame : stats["per_frame"]) {
      ASSERT_TRUE(frame["stages_ms"].contains(stage)) << stage;
    }
  }
  for (const auto& frame : stats["per_frame"]) {
    for (const char* key : {"tracking_cpu_ms", "preemptions", "mapping_ms"}) {
      ASSERT_TRUE(frame.contains(key)) << key;
    }
  }
  // The per-frame indices are the dataset's, increasing (dropped frames leave gaps).
  int last_index = -1;
  for (const auto& frame : stats["per_frame"]) {
    EXPECT_GT(frame["index"].get<int>(), last_index);
    last_index = frame["index"].get<int>();
  }
}

}  // namespace
