#include "render/synth_dataset.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "mapping/io/atomic_file.h"
#include "mapping/io/camera_file.h"
#include "mapping/io/trajectory.h"
#include "render/synth_scenario.h"

namespace lcv::render {
namespace {

namespace fs = std::filesystem;

fs::path TempDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() /
                       ("lcv_render_test_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  return dir;
}

TEST(WriteSynthDataset, WritesTheDatasetLayout) {
  const fs::path dir = TempDir("layout");
  SynthDatasetOptions options;
  options.scenario = "desk";
  options.camera_model = slam::CameraModel::kFisheye;
  options.frames = 3;
  options.cols = 160;
  options.rows = 96;
  options.seed = 5;
  options.out_dir = dir.string();
  std::ostringstream progress;
  const SynthDatasetReport report = WriteSynthDataset(options, &progress);
  EXPECT_EQ(report.frames_written, 6);
  EXPECT_NE(progress.str().find("synth: client 3/3"), std::string::npos) << progress.str();

  const Scenario scenario = MakeScenario("desk", 3, 5);
  for (const std::string seq : {"map", "client"}) {
    const fs::path s = dir / seq;
    for (int i = 0; i < 3; ++i) {
      const cv::Mat image = cv::imread((s / "images" / ("00000" + std::to_string(i) + ".png")).string(),
                                       cv::IMREAD_UNCHANGED);
      ASSERT_FALSE(image.empty()) << s << " frame " << i;
      EXPECT_EQ(image.cols, 160);
      EXPECT_EQ(image.rows, 96);
      EXPECT_EQ(image.type(), CV_8UC3);
    }
    const slam::CameraParams camera = mapping::ReadCameraFile((s / "camera.yaml").string());
    const slam::CameraParams expected = SynthCamera(slam::CameraModel::kFisheye, 160, 96, scenario.fps);
    EXPECT_EQ(camera.model, slam::CameraModel::kFisheye);
    EXPECT_EQ(camera.fx, expected.fx);
    EXPECT_EQ(camera.distortion, expected.distortion);
    const auto trajectory =
        mapping::ReadTrajectory((s / "groundtruth.txt").string(), mapping::TrajectoryFormat::kTum);
    const auto& truth = seq == "map" ? scenario.map_cam_from_world : scenario.client_cam_from_world;
    ASSERT_EQ(trajectory.poses.size(), 3u);
    for (int i = 0; i < 3; ++i) {
      EXPECT_LT((trajectory.poses[i].cam_from_world.Center() - truth[i].Center()).norm(), 1e-12);
      EXPECT_LT(slam::AngularDistance(trajectory.poses[i].cam_from_world.rotation, truth[i].rotation), 1e-12);
    }
    const auto times = mapping::ReadTimesFile((s / "times.txt").string());
    ASSERT_EQ(times.size(), 3u);
    EXPECT_DOUBLE_EQ(times[2], trajectory.poses[2].timestamp);
  }
  const auto scene = nlohmann::json::parse(mapping::ReadFileBytes((dir / "scene.json").string()));
  EXPECT_EQ(scene.at("scenario"), "desk");
  EXPECT_EQ(scene.at("seed"), 5);
  ASSERT_EQ(scene.at("concealed").at("client").size(), 1u);
  EXPECT_TRUE(scene.at("concealed").at("map").empty());
  const int hidden = scene.at("concealed").at("client")[0];
  const auto& object = scene.at("objects").at(hidden);
  EXPECT_EQ(object.at("kind"), "privacy");
  EXPECT_LT(object.at("bbox_min")[0].get<double>(), object.at("bbox_max")[0].get<double>());
  int points_on_hidden = 0;
  for (const auto& p : scene.at("ground_truth_points")) {
    if (p.at("object_id") == hidden) {
      ++points_on_hidden;
      EXPECT_FALSE(p.at("in_client").get<bool>());
      // Inside the object's bounding box.
      for (int d = 0; d < 3; ++d) {
        EXPECT_GE(p.at("position")[d].get<double>(), object.at("bbox_min")[d].get<double>() - 1e-9);
        EXPECT_LE(p.at("position")[d].get<double>(), object.at("bbox_max")[d].get<double>() + 1e-9);
      }
    }
  }
  EXPECT_GT(points_on_hidden, 0);
  fs::remove_all(dir);
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

TEST(LcvSynth, SameArgumentsGiveIdenticalFiles) {
  const fs::path a = TempDir("cli_a"), b = TempDir("cli_b");
  const std::string args = " synth --scenario loop --camera equirectangular --frames 2 --size 128x64 --seed 9";
  ASSERT_EQ(RunCommand(std::string(LCV_BINARY) + args + " --out " + a.string() + " 2>/dev/null").substr(0, 2), "0:");
  ASSERT_EQ(RunCommand(std::string(LCV_BINARY) + args + " --out " + b.string() + " 2>/dev/null").substr(0, 2), "0:");
  int compared = 0;
  for (const auto& entry : fs::recursive_directory_iterator(a)) {
    if (!entry.is_regular_file()) continue;
    const fs::path other = b / fs::relative(entry.path(), a);
    ASSERT_TRUE(fs::exists(other)) << other;
    EXPECT_EQ(mapping::ReadFileBytes(entry.path().string()), mapping::ReadFileBytes(other.string()))
        << entry.path();
    ++compared;
  }
  EXPECT_EQ(compared, 1 + 2 * (2 + 3));  // scene.json; per sequence 2 images, camera, gt, times
  fs::remove_all(a);
  fs::remove_all(b);
}

TEST(LcvSynth, HelpAndUsageErrors) {
  const std::string help = RunCommand(std::string(LCV_BINARY) + " synth --help");
  EXPECT_EQ(help.substr(0, 2), "0:");
  EXPECT_NE(help.find("--scenario"), std::string::npos);
  EXPECT_NE(help.find("equirectangular"), std::string::npos);
  EXPECT_EQ(RunCommand(std::string(LCV_BINARY) + " synth --scenario moon --out /tmp/x 2>&1").substr(0, 2), "2:");
  EXPECT_EQ(RunCommand(std::string(LCV_BINARY) + " synth --size 12x3 --out /tmp/x 2>&1").substr(0, 2), "2:");
  EXPECT_EQ(RunCommand(std::string(LCV_BINARY) + " synth --camera pinhole --out /tmp/x 2>&1").substr(0, 2), "2:");
  const std::string zero = RunCommand(std::string(LCV_BINARY) + " synth --supersampling 0 --out /tmp/x 2>&1");
  EXPECT_EQ(zero.substr(0, 2), "2:");
  EXPECT_NE(zero.find("--supersampling"), std::string::npos) << zero;
  const std::string too_large = RunCommand(std::string(LCV_BINARY) +
                                           " synth --size 8192x4096 --out /tmp/x 2>&1");
  EXPECT_EQ(too_large.substr(0, 2), "2:");
  EXPECT_NE(too_large.find("16384"), std::string::npos) << too_large;
}

// A supersampled perspective frame is the average of the fine samples: the same scene and path
// rendered point-sampled at 3x the size and averaged over 3x3 blocks gives the same image (the
// synthetic camera keeps its field of view across sizes, and pixel centres line up). The scene
// file says how it was made.
TEST(LcvSynth, SupersamplingAveragesFineSamples) {
  const fs::path fine = TempDir("ss_fine"), three = TempDir("ss_three");
  const std::string args = " synth --scenario tracking --frames 1 --seed 2";
  ASSERT_EQ(RunCommand(std::string(LCV_BINARY) + args + " --size 480x270 --supersampling 1 --out " + fine.string() + " 2>/dev/null").substr(0, 2), "0:");
  ASSERT_EQ(RunCommand(std::string(LCV_BINARY) + args + " --size 160x90 --out " + three.string() + " 2>/dev/null").substr(0, 2), "0:");
  const cv::Mat fine_image = cv::imread((fine / "map/images/000000.png").string());
  const cv::Mat image = cv::imread((three / "map/images/000000.png").string());
  ASSERT_EQ(fine_image.size(), cv::Size(480, 270));
  ASSERT_EQ(image.size(), cv::Size(160, 90));
  cv::Mat averaged;
  cv::resize(fine_image, averaged, image.size(), 0, 0, cv::INTER_AREA);
  double max_difference = 0.0;
  cv::minMaxLoc(cv::abs(averaged - image), nullptr, &max_difference);
  EXPECT_LE(max_difference, 1.0);
  const nlohmann::json scene = nlohmann::json::parse(mapping::ReadFileBytes((three / "scene.json").string()));
  EXPECT_EQ(scene.at("supersampling").get<int>(), 3);
  fs::remove_all(fine);
  fs::remove_all(three);
}

}  // namespace
}  // namespace lcv::render
