// `lcv slam --map-in LINES` on bad or unusable line clouds (issue 11, "Bad input"): the user is
// told what is wrong with the named file, tracking goes on in the client's own frame, exit 0,
// and the stats say `relocalized: false`.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mapping/io/map_file.h"
#include "mapping/line_cloud.h"
#include "mapping/synthetic_map.h"
#include "tests/support/cli_run.h"

namespace lcv {
namespace {

namespace fs = std::filesystem;

class SlamLineCloudCliTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = (fs::path(::testing::TempDir()) / ("lcv_slam_lines_" + std::to_string(::getpid())))
               .string();
    fs::create_directories(dir_);
    // A short rendered client sequence.
    const test::CliResult synth = test::RunLcv(
        "synth --scenario tracking --camera perspective --frames 30 --seed 3 --out " + dir_ +
            "/scene",
        dir_);
    ASSERT_EQ(synth.exit_code, 0) << synth.err;
    // A line cloud of some other synthetic street (not the rendered one).
    mapping::SyntheticMapOptions options;
    options.num_points = 400;
    options.num_keyframes = 10;
    cloud_ = mapping::ConvertToLineCloud(mapping::MakeSyntheticPointMap(options), {});
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  // Runs the client with map_in; returns the result and parses the stats.
  static test::CliResult RunClient(const std::string& map_in, nlohmann::json* stats) {
    const std::string stats_path = dir_ + "/stats.json";
    fs::remove(stats_path);
    const test::CliResult r = test::RunLcv(
        "slam --dataset " + dir_ + "/scene/client --deterministic --map-in " + map_in +
            " --trajectory-out " + dir_ + "/t.txt --stats-out " + stats_path,
        dir_);
    std::ifstream in(stats_path);
    if (in) *stats = nlohmann::json::parse(in);
    return r;
  }

  static std::string dir_;
  static slam::Map cloud_;
};
std::string SlamLineCloudCliTest::dir_;
slam::Map SlamLineCloudCliTest::cloud_;

TEST_F(SlamLineCloudCliTest, LinesWithoutServerKeyframesAreNamedAndTrackingGoesOn) {
  slam::Map map = cloud_;
  map.server_keyframes.clear();
  for (auto& [id, line] : map.lines) line.server_keyframe_ids.clear();
  const std::string path = dir_ + "/no_server_keyframes.lcmap";
  mapping::WriteMap(map, path);
  nlohmann::json stats;
  const test::CliResult r = RunClient(path, &stats);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find(path), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("no server keyframes"), std::string::npos) << r.err;
  EXPECT_FALSE(stats.at("relocalized").get<bool>());
  EXPECT_TRUE(stats.at("relocalization_time_s").is_null());
  EXPECT_GT(stats.at("tracked").get<int>(), 20);
}

TEST_F(SlamLineCloudCliTest, LinesWithoutDescriptorsAreNamed) {
  slam::Map map = cloud_;
  for (auto& [id, line] : map.lines) line.descriptor.reset();
  const std::string path = dir_ + "/no_descriptors.lcmap";
  mapping::WriteMap(map, path);
  nlohmann::json stats;
  const test::CliResult r = RunClient(path, &stats);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("none of the"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("has a descriptor"), std::string::npos) << r.err;
  EXPECT_FALSE(stats.at("relocalized").get<bool>());
}

TEST_F(SlamLineCloudCliTest, LineCloudOfAnotherPlaceIsReportedNotRelocalized) {
  const std::string path = dir_ + "/elsewhere.lcmap";
  mapping::WriteMap(cloud_, path);
  nlohmann::json stats;
  const test::CliResult r = RunClient(path, &stats);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("not relocalized in " + path), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("not relocalized after"), std::string::npos) << r.out;
  EXPECT_FALSE(stats.at("relocalized").get<bool>());
  EXPECT_FALSE(stats.at("trajectory_in_line_cloud_frame").get<bool>());
  EXPECT_GT(stats.at("line_cloud").at("attempts").get<int>(), 0);
  // One record per attempt, each failed with a reason.
  const nlohmann::json& log = stats.at("line_cloud").at("attempt_log");
  ASSERT_EQ(static_cast<int>(log.size()), stats.at("line_cloud").at("attempts").get<int>());
  for (const nlohmann::json& attempt : log) {
    EXPECT_FALSE(attempt.at("success").get<bool>());
    EXPECT_FALSE(attempt.at("failure").get<std::string>().empty());
    EXPECT_GE(attempt.at("timestamp").get<double>(), 0.0);
  }
  EXPECT_EQ(stats.at("restored_points").get<int>(), 0);
  EXPECT_GT(stats.at("tracked").get<int>(), 20);
}

// --localization-only promises an unchanged map and no keyframes; a line cloud alone can only be
// tracked in by a client that maps on its own. Refused before any frame, naming the map, and no
// trajectory is written (it used to be accepted, and the client made keyframes all the same).
TEST_F(SlamLineCloudCliTest, LocalizationOnlyInALineCloudAloneIsRefused) {
  const std::string path = dir_ + "/localization_only.lcmap";
  mapping::WriteMap(cloud_, path);
  const std::string trajectory = dir_ + "/localization_only.txt";
  fs::remove(trajectory);
  const test::CliResult r = test::RunLcv("slam --dataset " + dir_ +
                                             "/scene/client --deterministic --localization-only "
                                             "--map-in " + path + " --trajectory-out " +
                                             trajectory,
                                         dir_);
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find(path), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("localization_only"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(trajectory));
}

}  // namespace
}  // namespace lcv
