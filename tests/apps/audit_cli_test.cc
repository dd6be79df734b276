// `lcv audit` end to end through the built binary: exit codes, report files, planted leaks.
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mapping/io/map_file.h"
#include "tests/privacy/line_cloud_fixture.h"

namespace lcv {
namespace {

namespace fs = std::filesystem;

int RunLcv(const std::string& args, const std::string& out_file = "/dev/null") {
  const std::string command = std::string(LCV_BINARY) + " " + args + " > " + out_file + " 2>&1";
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

class AuditCliTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::path(::testing::TempDir()) / "audit_cli";
    fs::create_directories(dir_);
    const slam::Map points = privacy::testing::MakeStreetPointMap(2000, 71);
    slam::Map lines = privacy::testing::MakeLineCloud(points, 71);
    mapping::WriteMap(points, (dir_ / "points.json").string());
    mapping::WriteMap(lines, (dir_ / "lines.lcmap").string());
    // Planted leak: the same file with restored points X'.
    int k = 0;
    for (auto& [id, l] : lines.lines) {
      if (k++ < 3) l.restored_point = points.points.at(id).position;
    }
    mapping::WriteMap(lines, (dir_ / "leaky.lcmap").string());
  }
  static std::string Path(const std::string& name) { return (dir_ / name).string(); }
  static fs::path dir_;
};
fs::path AuditCliTest::dir_;

TEST_F(AuditCliTest, HelpExitsZeroAndListsOptions) {
  const std::string out = Path("help.txt");
  EXPECT_EQ(RunLcv("audit --help", out), 0);
  const std::string text = ReadText(out);
  for (const char* flag : {"--report", "--client", "--scene", "--concealed", "--reference",
                           "--fail-on", "--epsilon"}) {
    EXPECT_NE(text.find(flag), std::string::npos) << flag;
  }
}

TEST_F(AuditCliTest, CleanLineCloudPasses) {
  const std::string report = Path("clean/report.json");
  fs::create_directories(dir_ / "clean");
  const std::string out = Path("clean.txt");
  ASSERT_EQ(RunLcv("audit " + Path("lines.lcmap") + " --reference " + Path("points.json") +
                       " --report " + report + " --fail-on density@0.1m=0.9",
                   out),
            0)
      << ReadText(out);
  const nlohmann::json j = nlohmann::json::parse(ReadText(report));
  EXPECT_TRUE(j.at("passed").get<bool>());
  for (const auto& a : j.at("attacks")) {
    EXPECT_TRUE(fs::exists(dir_ / "clean" / a.at("risk_file").get<std::string>()));
  }
  EXPECT_NE(ReadText(out).find("audit PASSED"), std::string::npos);
}

TEST_F(AuditCliTest, PlantedRestoredPointsFailWithExit3) {
  const std::string report = Path("leaky.json");
  EXPECT_EQ(RunLcv("audit " + Path("leaky.lcmap") + " --report " + report +
                   " --skip-density --skip-visibility"),
            3);
  const nlohmann::json j = nlohmann::json::parse(ReadText(report));
  EXPECT_FALSE(j.at("passed").get<bool>());
  EXPECT_FALSE(j.at("checks").at(0).at("passed").get<bool>());
}

TEST_F(AuditCliTest, ThresholdFailsWithExit3) {
  EXPECT_EQ(RunLcv("audit " + Path("lines.lcmap") + " --reference " + Path("points.json") +
                   " --report " + Path("strict.json") + " --fail-on density@5%=0.01 "
                   "--skip-visibility"),
            3);
}

TEST_F(AuditCliTest, BadInputAndUsage) {
  const std::string out = Path("bad.txt");
  EXPECT_EQ(RunLcv("audit /nonexistent/map.lcmap --report " + Path("x.json"), out), 1);
  EXPECT_NE(ReadText(out).find("/nonexistent/map.lcmap"), std::string::npos) << ReadText(out);
  {
    std::ofstream f(Path("regions.json"));
    f << R"({"regions": [{"min": [0, 0], "max": [1, 1, 1]}]})";
  }
  EXPECT_EQ(RunLcv("audit " + Path("lines.lcmap") + " --client " + Path("lines.lcmap") +
                       " --concealed " + Path("regions.json") + " --report " + Path("x.json"),
                   out),
            1);
  EXPECT_NE(ReadText(out).find("regions.json: /regions/0/min"), std::string::npos) << ReadText(out);
  EXPECT_EQ(RunLcv("audit " + Path("lines.lcmap") + " --report " + Path("x.json") +
                       " --fail-on density@0.1=0.05",
                   out),
            2);
  EXPECT_NE(ReadText(out).find("needs a unit"), std::string::npos) << ReadText(out);
  EXPECT_EQ(RunLcv("audit " + Path("lines.lcmap")), 2) << "--report is required";
}

}  // namespace
}  // namespace lcv
