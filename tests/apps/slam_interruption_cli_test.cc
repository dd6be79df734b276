// A line-cloud client whose camera jumps (issue 11: relocalization after a tracking loss works in
// the line cloud). The rendered `overlap` client of seed 1 with frames 12-39 left out and the
// timestamps renumbered, as bench/gap_dataset.py --retime makes it: the camera moves 19 m between
// two consecutive frames. Tracking found a wrong pose that X' and line matches agreed with and
// went on from there. The line-cloud check (TrackingSettings::line_cloud_check_*) refuses that
// pose, the registered map is kept, a new one starts and registers into the line cloud again,
// and the trajectory joins both.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/cli_run.h"

namespace lcv {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> ReadLines(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) {
    if (!line.empty()) lines.push_back(line);
  }
  return lines;
}

// dst: the sequence src without frames [first, end), timestamps renumbered at 0.1 s.
void WriteJumpSequence(const std::string& src, const std::string& dst, int first, int end) {
  fs::create_directories(dst + "/images");
  fs::copy_file(src + "/camera.yaml", dst + "/camera.yaml");
  const std::vector<std::string> truth = ReadLines(src + "/groundtruth.txt");
  std::ofstream times(dst + "/times.txt"), gt(dst + "/groundtruth.txt");
  int j = 0;
  for (int i = 0; i < static_cast<int>(truth.size()); ++i) {
    if (i >= first && i < end) continue;
    char name[32];
    std::snprintf(name, sizeof(name), "/images/%06d.png", i);
    char renamed[32];
    std::snprintf(renamed, sizeof(renamed), "/images/%06d.png", j);
    fs::create_symlink(fs::absolute(src + name), dst + renamed);
    std::ostringstream stamp;
    stamp << std::fixed << std::setprecision(1) << 0.1 * j;
    times << stamp.str() << "\n";
    gt << stamp.str() << truth[i].substr(truth[i].find(' ')) << "\n";
    ++j;
  }
}

// Renders the `overlap` pair of camera and seed 1, publishes the server map as a line cloud, runs
// the client with the jump, and checks it ends in the server frame near the truth.
void CheckJumpEndsInTheRightPlace(const std::string& camera, double max_rmse) {
  const std::string dir =
      (fs::path(::testing::TempDir()) / ("lcv_jump_" + camera + "_" + std::to_string(::getpid()))).string();
  fs::create_directories(dir);
  auto run = [&](const std::string& arguments) {
    const test::CliResult r = test::RunLcv(arguments, dir);
    EXPECT_EQ(r.exit_code, 0) << arguments << "\n" << r.err;
    return r;
  };
  run("synth --scenario overlap --camera " + camera + " --frames 100 --seed 1 --out " + dir +
      "/scene");
  run("slam --dataset " + dir + "/scene/map --deterministic --trajectory-out " + dir +
      "/server.txt --map-out " + dir + "/points.lcmap");
  run("map transform " + dir + "/points.lcmap " + dir + "/aligned.lcmap --sim3-align-to " + dir +
      "/scene/map/groundtruth.txt");
  run("map convert --to-lines " + dir + "/aligned.lcmap " + dir + "/lines.lcmap");
  ASSERT_FALSE(::testing::Test::HasFailure());
  WriteJumpSequence(dir + "/scene/client", dir + "/jump", 12, 40);
  run("slam --dataset " + dir + "/jump --deterministic --map-in " + dir +
      "/lines.lcmap --trajectory-out " + dir + "/t.txt --stats-out " + dir + "/stats.json");
  const test::CliResult ape = run("eval ape --gt " + dir + "/jump/groundtruth.txt --est " + dir +
                                  "/t.txt --align none --json");
  ASSERT_FALSE(::testing::Test::HasFailure());
  std::ifstream stats_in(dir + "/stats.json");
  const nlohmann::json stats = nlohmann::json::parse(stats_in);
  const nlohmann::json error = nlohmann::json::parse(ape.out);
  std::printf("%s: refusals %d, maps kept %d, %d poses, APE %.3f m\n",
              camera.c_str(), stats["line_cloud_check_refusals"].get<int>(),
              stats["maps_kept"].get<int>(),
              error["matched"].get<int>(), error["rmse"].get<double>());
  EXPECT_GE(stats["line_cloud_check_refusals"].get<int>(), 1);
  EXPECT_TRUE(stats["relocalized"].get<bool>());
  EXPECT_TRUE(stats["trajectory_in_line_cloud_frame"].get<bool>());  // the new map registered
  EXPECT_GE(error["matched"].get<int>(), 65);  // of 72: both maps' frames
  EXPECT_LT(error["rmse"].get<double>(), max_rmse);
  fs::remove_all(dir);
}


// The recovery search found the wrong pose (8 m off); APE 6.98 m without the check, 0.67 m with
// it (the rest is the monocular drift after the server map's end).
TEST(SlamInterruptionCliTest, APerspectiveCameraThatJumpsEndsInTheRightPlace) {
  CheckJumpEndsInTheRightPlace("perspective", 1.5);
}

// The motion model itself tracked 95 matches at the wrong pose (656 on the frame before): the
// collapse of the matches triggers the check. 10.50 m without it, 0.41 m with it.
TEST(SlamInterruptionCliTest, AnEquirectangularCameraThatJumpsEndsInTheRightPlace) {
  CheckJumpEndsInTheRightPlace("equirectangular", 1.5);
}

}  // namespace
}  // namespace lcv
