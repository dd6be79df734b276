// `lcv map import|convert|info|export` through the built binary: exit codes, outputs, messages.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "mapping/io/atomic_file.h"
#include "mapping/io/map_file.h"
#include "mapping/synthetic_map.h"

#include "tests/support/cli_run.h"

namespace lcv {
namespace {

namespace fs = std::filesystem;

using RunResult = test::CliResult;

class MapCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lcv_map_cli_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    mapping::SyntheticMapOptions o;
    o.num_points = 300;
    o.num_keyframes = 8;
    o.seed = 2;
    points_ = mapping::MakeSyntheticPointMap(o);
    mapping::WriteMap(points_, Path("points.lcmap"));
    mapping::WriteMap(points_, Path("points.json"));
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Path(const std::string& name) const { return (dir_ / name).string(); }

  static std::string Slurp(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  }

  RunResult Run(const std::string& arguments) const { return test::RunLcv(arguments, dir_.string()); }

  static int CountLines(const std::string& s) {
    return static_cast<int>(std::count(s.begin(), s.end(), '\n'));
  }

  fs::path dir_;
  slam::Map points_;
};

TEST_F(MapCliTest, InfoOfAPointMap) {
  for (const char* name : {"points.lcmap", "points.json"}) {
    const RunResult r = Run("map info " + Path(name) + " --json");
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto info = nlohmann::json::parse(r.out);
    EXPECT_EQ(info["keyframes"], 8);
    EXPECT_EQ(info["server_keyframes"], 0);
    EXPECT_EQ(info["points"], 300);
    EXPECT_EQ(info["lines"], 0);
    EXPECT_EQ(info["published"], false);
    EXPECT_EQ(info["schema_version"], 1);
    EXPECT_EQ(info["encoding"],
              std::string(name).find(".json") != std::string::npos ? "json" : "msgpack");
    EXPECT_EQ(info["bounds"]["min"].size(), 3u);
  }
  const RunResult text = Run("map info " + Path("points.lcmap"));
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_LE(CountLines(text.out), 10);
  EXPECT_NE(text.out.find("published line cloud: no"), std::string::npos) << text.out;
}

TEST_F(MapCliTest, ConvertPublishesALineCloud) {
  const RunResult r = Run("map convert --to-lines " + Path("points.lcmap") + " " +
                          Path("lines.lcmap") + " --seed 5");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_LE(CountLines(r.out), 10);
  const slam::Map lines = mapping::ReadMap(Path("lines.lcmap"));
  EXPECT_TRUE(slam::IsPublishedLineCloud(lines));
  EXPECT_EQ(lines.lines.size(), 300u);
  for (const auto& [id, point] : points_.points) {
    ASSERT_TRUE(lines.lines.count(id));
    EXPECT_LT(lines.lines.at(id).line.Distance(point.position), 1e-9);
  }
  const RunResult info = Run("map info " + Path("lines.lcmap") + " --json");
  ASSERT_EQ(info.exit_code, 0) << info.err;
  const auto j = nlohmann::json::parse(info.out);
  EXPECT_EQ(j["published"], true);
  EXPECT_EQ(j["keyframes"], 0);
  EXPECT_EQ(j["server_keyframes"], 8);
  EXPECT_EQ(j["points"], 0);
  EXPECT_EQ(j["lines"], 300);
  // Same seed, same bytes.
  ASSERT_EQ(
      Run("map convert --to-lines " + Path("points.json") + " " + Path("again.lcmap") + " --seed 5")
          .exit_code,
      0);
  EXPECT_EQ(Slurp(Path("lines.lcmap")), Slurp(Path("again.lcmap")));
  // --information covariance: the paper's eq. 1 of each point's covariance, which differs from
  // the default (published data only) and which the default rule replaces on re-publishing.
  ASSERT_EQ(Run("map convert --to-lines " + Path("points.lcmap") + " " + Path("eq1.lcmap") +
                " --seed 5 --information covariance")
                .exit_code,
            0);
  const slam::Map eq1 = mapping::ReadMap(Path("eq1.lcmap"));
  int differ = 0;
  for (const auto& [id, line] : lines.lines) {
    differ += (eq1.lines.at(id).information - line.information).norm() >
              1e-6 * line.information.norm();
  }
  EXPECT_EQ(differ, 300);
  ASSERT_EQ(Run("map convert --to-lines " + Path("eq1.lcmap") + " " + Path("re.lcmap") + " --seed 5")
                .exit_code,
            0);
  const slam::Map republished = mapping::ReadMap(Path("re.lcmap"));
  for (const auto& [id, line] : lines.lines) {
    EXPECT_LT((republished.lines.at(id).information - line.information).norm(),
              1e-9 * line.information.norm());
  }
}

// --copy re-encodes without a change: MessagePack -> JSON -> MessagePack gives the same bytes, for
// a point map and for a line cloud; nothing is published on the way.
TEST_F(MapCliTest, CopyReencodesAMapUnchanged) {
  const RunResult to_json = Run("map convert --copy " + Path("points.lcmap") + " " + Path("copy.json"));
  ASSERT_EQ(to_json.exit_code, 0) << to_json.err;
  EXPECT_NE(to_json.out.find("not a published line cloud"), std::string::npos) << to_json.out;
  EXPECT_EQ(nlohmann::json::parse(Slurp(Path("copy.json")))["points"].size(), 300u);
  ASSERT_EQ(Run("map convert --copy " + Path("copy.json") + " " + Path("back.lcmap")).exit_code, 0);
  EXPECT_EQ(Slurp(Path("points.lcmap")), Slurp(Path("back.lcmap")));

  ASSERT_EQ(Run("map convert --to-lines " + Path("points.lcmap") + " " + Path("lines.lcmap")).exit_code,
            0);
  ASSERT_EQ(Run("map convert --copy " + Path("lines.lcmap") + " " + Path("lines.json")).exit_code, 0);
  ASSERT_EQ(Run("map convert --copy " + Path("lines.json") + " " + Path("lines2.lcmap")).exit_code, 0);
  EXPECT_EQ(Slurp(Path("lines.lcmap")), Slurp(Path("lines2.lcmap")));
  EXPECT_TRUE(slam::IsPublishedLineCloud(mapping::ReadMap(Path("lines.json"))));

  // One conversion at a time; a corrupt input leaves nothing behind.
  EXPECT_EQ(Run("map convert --copy --to-lines " + Path("points.lcmap") + " " + Path("o.lcmap")).exit_code,
            2);
  EXPECT_EQ(Run("map convert --copy " + Path("points.lcmap") + " " + Path("o.lcmap") +
                " --mitigate drop").exit_code,
            2);
  mapping::WriteFileAtomically(Path("bad.lcmap"), "not a map");
  const RunResult bad = Run("map convert --copy " + Path("bad.lcmap") + " " + Path("o.json"));
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("bad.lcmap"), std::string::npos) << bad.err;
  EXPECT_FALSE(fs::exists(Path("o.lcmap")));
  EXPECT_FALSE(fs::exists(Path("o.json")));
}

// Mitigation (audit check 5): the riskiest share of the lines is dropped, or re-randomized about
// its hidden point; the result is still a published line cloud.
TEST_F(MapCliTest, ConvertMitigatesTheRiskiestLines) {
  RunResult r = Run("map convert --to-lines " + Path("points.lcmap") + " " + Path("dropped.lcmap") +
                    " --seed 3 --mitigate drop --fraction 0.25");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const slam::Map dropped = mapping::ReadMap(Path("dropped.lcmap"));
  EXPECT_TRUE(slam::IsPublishedLineCloud(dropped));
  EXPECT_EQ(dropped.lines.size(), points_.points.size() - points_.points.size() / 4);

  r = Run("map convert --to-lines " + Path("points.lcmap") + " " + Path("turned.lcmap") +
          " --seed 3 --mitigate rerandomize --fraction 0.25");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  ASSERT_EQ(Run("map convert --to-lines " + Path("points.lcmap") + " " + Path("plain.lcmap") +
                " --seed 3").exit_code, 0);
  const slam::Map turned = mapping::ReadMap(Path("turned.lcmap"));
  const slam::Map plain = mapping::ReadMap(Path("plain.lcmap"));
  ASSERT_EQ(turned.lines.size(), points_.points.size());
  int changed = 0;
  for (const auto& [id, line] : turned.lines) {
    // Every line, turned or not, still passes through its hidden point.
    EXPECT_LT(line.line.Distance(points_.points.at(id).position), 1e-6) << "line " << id;
    changed += line.line.direction != plain.lines.at(id).line.direction;
  }
  EXPECT_EQ(changed, static_cast<int>(points_.points.size() / 4));

  EXPECT_EQ(Run("map convert --to-lines " + Path("points.lcmap") + " " + Path("x.lcmap") +
                " --mitigate shuffle").exit_code, 2);
  EXPECT_EQ(Run("map convert --to-lines " + Path("points.lcmap") + " " + Path("x.lcmap") +
                " --mitigate drop --risk " + Path("missing.csv")).exit_code, 1);
}

TEST_F(MapCliTest, ExportPlyAndPcd) {
  ASSERT_EQ(
      Run("map convert --to-lines " + Path("points.lcmap") + " " + Path("lines.json")).exit_code,
      0);
  RunResult r = Run("map export " + Path("lines.json") + " " + Path("lines.ply") + " --cameras");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string ply = Slurp(Path("lines.ply"));
  EXPECT_EQ(ply.rfind("ply\nformat binary_little_endian 1.0\n", 0), 0u);
  EXPECT_NE(ply.find("element vertex " + std::to_string(2 * 300 + 8) + "\n"), std::string::npos);
  EXPECT_NE(ply.find("element edge 300\n"), std::string::npos);
  r = Run("map export " + Path("points.lcmap") + " " + Path("points.pcd") + " --ascii");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string pcd = Slurp(Path("points.pcd"));
  EXPECT_NE(pcd.find("POINTS 300\nDATA ascii\n"), std::string::npos);
  EXPECT_EQ(Run("map export " + Path("points.lcmap") + " " + Path("points.xyz")).exit_code, 2);
}

TEST_F(MapCliTest, ImportAColmapTextModel) {
  const fs::path model = dir_ / "colmap";
  fs::create_directories(model);
  std::ofstream(model / "cameras.txt") << "# Camera list with one line of data per camera:\n"
                                          "1 SIMPLE_RADIAL 640 480 500 320 240 0.01\n";
  std::ofstream(model / "images.txt") << "# Image list with two lines of data per image:\n"
                                         "1 1 0 0 0 0 0 0 1 a.png\n"
                                         "320 240 1 420 240 2 100 100 -1\n"
                                         "2 1 0 0 0 -1 0 0 1 b.png\n"
                                         "220 240 1 320 240 2\n"
                                         "3 1 0 0 0 -2 0 0 1 c.png\n"
                                         "\n";
  std::ofstream(model / "points3D.txt") << "1 0 0 5 255 0 0 0.7 1 0 2 0\n"
                                           "2 1 0 5 0 255 0 0.3 1 1 2 1\n";
  const RunResult r = Run("map import --colmap " + model.string() + " " + Path("colmap.lcmap"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const slam::Map map = mapping::ReadMap(Path("colmap.lcmap"));
  EXPECT_EQ(map.cameras.size(), 1u);
  ASSERT_EQ(map.keyframes.size(), 3u);
  ASSERT_EQ(map.points.size(), 2u);
  // keyframe = IMAGE_ID + 1, point = POINT3D_ID + 1 + 3.
  EXPECT_EQ(map.keyframes.at(2).keypoints.size(), 3u);
  EXPECT_EQ(map.keyframes.at(3).keypoints.size(), 2u);
  EXPECT_TRUE(map.keyframes.at(4).keypoints.empty());
  EXPECT_EQ(map.points.at(5).position, Eigen::Vector3d(0, 0, 5));
  EXPECT_EQ(map.points.at(6).observations.size(), 2u);
  EXPECT_EQ(map.keyframes.at(2).keypoints[0].x, 319.5f);
  // A broken model: exit 1 with file and line.
  std::ofstream(model / "points3D.txt") << "1 0 0 5 255 0 0 0.7 1 0 2\n";
  const RunResult bad = Run("map import --colmap " + model.string() + " " + Path("bad.lcmap"));
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("points3D.txt:1:"), std::string::npos) << bad.err;
  EXPECT_FALSE(fs::exists(Path("bad.lcmap")));
}

TEST_F(MapCliTest, CompareAPointMapWithItsLineCloud) {
  ASSERT_EQ(Run("map convert --to-lines " + Path("points.lcmap") + " " + Path("lines.lcmap")).exit_code,
            0);
  RunResult r = Run("map compare " + Path("points.lcmap") + " " + Path("lines.lcmap") +
                    " --report " + Path("compare.json"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("keyframes: 8 in common"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("point-line 300"), std::string::npos) << r.out;
  EXPECT_LE(CountLines(r.out), 10);
  const auto report = nlohmann::json::parse(Slurp(Path("compare.json")));
  EXPECT_EQ(report["keyframes"]["common"], 8);
  EXPECT_EQ(report["structure"]["point-line"]["count"], 300);
  EXPECT_LT(report["structure"]["point-line"]["max"].get<double>(), 1e-9);
  EXPECT_EQ(report["per_point_or_line"].size(), 300u);
  EXPECT_EQ(report["per_keyframe"][0]["map"], "server");
  // --align needs keyframes in common: a map without any is refused, nothing written.
  slam::Map empty = points_;
  empty.keyframes.clear();
  empty.points.clear();
  mapping::WriteMap(empty, Path("empty.lcmap"));
  r = Run("map compare " + Path("points.lcmap") + " " + Path("empty.lcmap") + " --align --report " +
          Path("refused.json"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("cannot align"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(Path("refused.json")));
}

TEST_F(MapCliTest, CorruptOrTruncatedMapsFailCleanly) {
  const std::string bytes = Slurp(Path("points.lcmap"));
  mapping::WriteFileAtomically(Path("truncated.lcmap"), bytes.substr(0, bytes.size() / 2));
  std::string flipped = Slurp(Path("points.json"));
  flipped.replace(flipped.find("\"covariance\":[") + 14, 1, "-");
  mapping::WriteFileAtomically(Path("corrupt.json"), flipped);
  for (const char* name : {"truncated.lcmap", "corrupt.json", "missing.lcmap"}) {
    SCOPED_TRACE(name);
    for (const std::string& command :
         {"map info " + Path(name), "map convert --to-lines " + Path(name) + " " + Path("o.lcmap"),
          "map export " + Path(name) + " " + Path("o.ply"),
          "map compare " + Path("points.lcmap") + " " + Path(name) + " --report " + Path("o.json")}) {
      const RunResult r = Run(command);
      EXPECT_EQ(r.exit_code, 1) << command;
      EXPECT_NE(r.err.find(Path(name)), std::string::npos) << r.err;
      EXPECT_EQ(r.err.find("internal error"), std::string::npos) << r.err;
    }
    EXPECT_FALSE(fs::exists(Path("o.lcmap")));
    EXPECT_FALSE(fs::exists(Path("o.ply")));
    EXPECT_FALSE(fs::exists(Path("o.json")));
  }
  EXPECT_NE(Run("map info " + Path("truncated.lcmap")).err.find("truncated"), std::string::npos);
}

TEST_F(MapCliTest, UsageErrorsAndHelp) {
  EXPECT_EQ(Run("map convert " + Path("points.lcmap") + " " + Path("o.lcmap")).exit_code, 2);
  EXPECT_EQ(Run("map info").exit_code, 2);
  EXPECT_EQ(Run("map info " + Path("points.lcmap") + " --bogus").exit_code, 2);
  EXPECT_EQ(Run("map import " + Path("o.lcmap")).exit_code, 2);  // --colmap missing
  EXPECT_EQ(Run("map convert --to-lines a b --seed -1").exit_code, 2);
  const RunResult rule = Run("map convert --to-lines " + Path("points.lcmap") + " " +
                             Path("o.lcmap") + " --information exact");
  EXPECT_EQ(rule.exit_code, 2);
  EXPECT_NE(rule.err.find("--information"), std::string::npos) << rule.err;
  EXPECT_FALSE(std::filesystem::exists(Path("o.lcmap")));
  for (const char* command : {"map import", "map convert", "map info", "map export", "map compare"}) {
    const RunResult r = Run(std::string(command) + " --help");
    EXPECT_EQ(r.exit_code, 0) << command;
    EXPECT_NE(r.out.find("example"), std::string::npos) << command;
  }
}

}  // namespace
}  // namespace lcv
