// `lcv demo` end to end (its own test executable: it renders and maps two small scenes, ~20 s),
// then the Desk experiment's outputs reused: the concealed-object check on the real desk client
// map with a planted leak, and `lcv localize` in the desk's published line cloud.
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mapping/io/atomic_file.h"
#include "mapping/io/map_file.h"
#include "privacy/audit.h"
#include "privacy/concealed_check.h"
#include "privacy/concealed_regions.h"
#include "privacy/reference_match.h"
#include "tests/support/cli_run.h"

namespace lcv {
namespace {

// A hidden point of the concealed object itself: in its box and 2 cm or more from the faces it
// rests on (where the client sees the desk it stood on, privacy::ConcealedRegion).
bool OnTheObject(const privacy::ConcealedRegion& region, const Eigen::Vector3d& x) {
  if (!region.box.contains(x)) return false;
  for (int axis = 0; axis < 3; ++axis) {
    if (region.rests_min[axis] && x[axis] < region.box.min()[axis] + 0.02) return false;
    if (region.rests_max[axis] && x[axis] > region.box.max()[axis] - 0.02) return false;
  }
  return true;
}

namespace fs = std::filesystem;

class DemoCliTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // One folder per process: ctest runs each test of this suite as its own process, in
    // parallel, and each runs this set-up.
    dir_ = (fs::path(::testing::TempDir()) / ("lcv_demo_cli_" + std::to_string(::getpid())))
               .string();
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    demo_ = new test::CliResult(
        test::RunLcv("demo --out " + dir_ + "/out --frames 24 --desk-frames 40", dir_));
  }
  static void TearDownTestSuite() {
    delete demo_;
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }
  static std::string Out(const std::string& name) { return dir_ + "/out/" + name; }
  static std::string dir_;
  static test::CliResult* demo_;
};
std::string DemoCliTest::dir_;
test::CliResult* DemoCliTest::demo_ = nullptr;

TEST_F(DemoCliTest, EndsWithTheConcealedObjectAuditOfTheClientMap) {
  ASSERT_EQ(demo_->exit_code, 0) << demo_->out << demo_->err;
  EXPECT_NE(demo_->out.find("audit:       passed"), std::string::npos) << demo_->out;
  EXPECT_NE(demo_->out.find("concealed:   passed"), std::string::npos) << demo_->out;
  // The real LC-VSLAM client: relocalized in the line cloud, scored in the server's frame.
  EXPECT_NE(demo_->out.find("tracked in the line cloud, relocalized at"), std::string::npos)
      << demo_->out;
  EXPECT_NE(demo_->out.find("APE in the server's frame (no alignment)"), std::string::npos)
      << demo_->out;
  std::ifstream in(Out("desk_audit.json"));
  const nlohmann::json report = nlohmann::json::parse(in);
  bool concealed_ran = false;
  for (const auto& check : report.at("checks")) {
    if (check.at("name") != "concealed") continue;
    concealed_ran = !check.value("skipped", false);
    EXPECT_TRUE(check.at("passed").get<bool>());
    EXPECT_GT(check.at("details").at("concealed_lines").get<int>(), 0);
    EXPECT_GT(check.at("details").at("client_points_checked").get<int>(), 100);
    EXPECT_GT(check.at("details").at("restored_points_checked").get<int>(), 50);
  }
  EXPECT_TRUE(concealed_ran);
}

// The street's line cloud is published behind the privacy gate: the audit that passed it ran
// the default risk limits (its thresholds check lists every rule, each within its limit), and
// the published line cloud is what that audit judged.
TEST_F(DemoCliTest, StreetLineCloudPassesTheDefaultRiskLimits) {
  ASSERT_EQ(demo_->exit_code, 0) << demo_->err;
  const nlohmann::json audit = nlohmann::json::parse(mapping::ReadTextFile(Out("audit.json")));
  EXPECT_TRUE(audit.at("passed").get<bool>());
  std::vector<std::string> rules;
  for (const auto& check : audit.at("checks")) {
    if (check.at("name") != "thresholds") continue;
    for (const auto& rule : check.at("details").at("rules")) {
      EXPECT_TRUE(rule.at("passed").get<bool>()) << rule.dump();
      rules.push_back(rule.at("rule").get<std::string>());
    }
  }
  std::string joined;
  for (const std::string& r : rules) joined += (joined.empty() ? "" : ",") + r;
  EXPECT_EQ(joined, privacy::kDefaultFailRules);
  const slam::Map published = mapping::ReadMap(Out("line_cloud.lcmap"));
  EXPECT_TRUE(slam::IsPublishedLineCloud(published));
  for (const auto& attack : audit.at("attacks")) {
    EXPECT_EQ(attack.at("lines").get<std::size_t>(), published.lines.size());
  }
}

// The client's upload (`--map-out` of the LC-VSLAM client: its keyframes and points, X' with
// their lines, the server's lines and keyframes) publishes as a line cloud without X' and
// without client keypoints, keeping every server line.
TEST_F(DemoCliTest, ClientMapPublishesWithoutRestoredPointsOrKeypoints) {
  ASSERT_EQ(demo_->exit_code, 0) << demo_->err;
  const slam::Map client = mapping::ReadMap(Out("desk_client_map.lcmap"));
  const slam::Map server = mapping::ReadMap(Out("desk_line_cloud.lcmap"));
  int restored = 0;
  for (const auto& [id, line] : client.lines) restored += line.restored_point.has_value();
  ASSERT_GT(restored, 0);
  ASSERT_FALSE(client.keyframes.empty());
  const test::CliResult r = test::RunLcv(
      "map convert --to-lines " + Out("desk_client_map.lcmap") + " " + dir_ + "/upload.lcmap", dir_);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const slam::Map upload = mapping::ReadMap(dir_ + "/upload.lcmap");
  EXPECT_TRUE(slam::IsPublishedLineCloud(upload));
  EXPECT_TRUE(upload.keyframes.empty());
  EXPECT_TRUE(upload.points.empty());
  for (const auto& [id, line] : upload.lines) {
    EXPECT_FALSE(line.restored_point.has_value()) << "line " << id;
    EXPECT_TRUE(line.observations.empty()) << "line " << id;
  }
  for (const auto& [id, line] : server.lines) EXPECT_TRUE(upload.lines.count(id)) << id;
  EXPECT_GE(upload.lines.size(), server.lines.size() + client.points.size() / 2);
}

// Planted leak in the real client's X': a restored point put on a concealed line (one the client
// never observed) fails the check.
TEST_F(DemoCliTest, RestoredPointPlantedOnAConcealedLineFailsTheCheck) {
  ASSERT_EQ(demo_->exit_code, 0) << demo_->err;
  const slam::Map published = mapping::ReadMap(Out("desk_line_cloud.lcmap"));
  const slam::Map reference = mapping::ReadMap(Out("desk_server_points.lcmap"));
  slam::Map client = mapping::ReadMap(Out("desk_client_map.lcmap"));
  const privacy::ConcealedSpec spec =
      privacy::ReadSceneConcealedRegions(Out("desk/scene.json"));
  const privacy::ReferenceMatch match = privacy::MatchReference(published, reference);
  ASSERT_TRUE(privacy::CheckConcealedLines(published, client, spec, &match).passed());
  slam::Id victim = slam::kInvalidId;
  Eigen::Vector3d hidden = Eigen::Vector3d::Zero();
  std::size_t i = 0;
  for (const auto& [id, line] : published.lines) {
    if (i < match.matched.size() && match.matched[i] &&
        OnTheObject(spec.regions[0], match.hidden_points[i])) {
      victim = id;
      hidden = match.hidden_points[i];
      break;
    }
    ++i;
  }
  ASSERT_NE(victim, slam::kInvalidId);
  ASSERT_TRUE(client.lines.count(victim)) << "the client's map carries the server's lines";
  ASSERT_FALSE(client.lines.at(victim).restored_point) << "the client never saw the object";
  client.lines[victim].restored_point = hidden + Eigen::Vector3d(0.003, 0.0, 0.0);
  const slam::Keyframe& kf = client.keyframes.begin()->second;
  client.lines[victim].observations.push_back({kf.id, 0});
  const privacy::ConcealedCheckResult r =
      privacy::CheckConcealedLines(published, client, spec, &match);
  ASSERT_FALSE(r.passed());
  bool found = false;
  for (const auto& v : r.violations) found |= v.line_id == victim;
  EXPECT_TRUE(found);
}

// Planted leak in the real desk client map: a client point 5 mm from the hidden point of a
// concealed line (a point of the privacy object, which the client never saw) fails the check,
// in the library and through `lcv audit` (exit 3).
TEST_F(DemoCliTest, ClientPointPlantedNearAConcealedLineFailsTheCheck) {
  ASSERT_EQ(demo_->exit_code, 0) << demo_->err;
  const slam::Map published = mapping::ReadMap(Out("desk_line_cloud.lcmap"));
  const slam::Map reference = mapping::ReadMap(Out("desk_server_points.lcmap"));
  slam::Map client = mapping::ReadMap(Out("desk_client_map.lcmap"));
  const privacy::ConcealedSpec spec =
      privacy::ReadSceneConcealedRegions(Out("desk/scene.json"));
  ASSERT_EQ(spec.regions.size(), 1u);
  const privacy::ReferenceMatch match = privacy::MatchReference(published, reference);
  ASSERT_TRUE(privacy::CheckConcealedLines(published, client, spec, &match).passed());

  // A published line whose hidden point lies on the concealed object.
  slam::Id victim = slam::kInvalidId;
  Eigen::Vector3d hidden = Eigen::Vector3d::Zero();
  std::size_t i = 0;
  for (const auto& [id, line] : published.lines) {
    if (i < match.matched.size() && match.matched[i] &&
        OnTheObject(spec.regions[0], match.hidden_points[i])) {
      victim = id;
      hidden = match.hidden_points[i];
      break;
    }
    ++i;
  }
  ASSERT_NE(victim, slam::kInvalidId) << "the server map has points on the concealed object";
  const slam::Id planted = client.NextFreeId();
  client.points[planted].id = planted;
  client.points[planted].position = hidden + Eigen::Vector3d(0.005, 0.0, 0.0);
  const privacy::ConcealedCheckResult r =
      privacy::CheckConcealedLines(published, client, spec, &match);
  ASSERT_FALSE(r.passed());
  bool found = false;
  for (const auto& v : r.violations) {
    EXPECT_EQ(v.point_id, planted);
    EXPECT_EQ(v.region, spec.regions[0].name);
    found |= v.line_id == victim;
  }
  EXPECT_TRUE(found) << "the victim line is reported";

  mapping::WriteMap(client, dir_ + "/planted_client.lcmap");
  const test::CliResult audit = test::RunLcv(
      "audit " + Out("desk_line_cloud.lcmap") + " --client " + dir_ + "/planted_client.lcmap" +
          " --scene " + Out("desk/scene.json") + " --reference " + Out("desk_server_points.lcmap") +
          " --report " + dir_ + "/planted_audit.json",
      dir_);
  EXPECT_EQ(audit.exit_code, 3) << audit.out << audit.err;
}

// `lcv localize` in the desk's published line cloud (in the scene's frame): the client frames
// are found against the ground truth without alignment.
TEST_F(DemoCliTest, LocalizeClientFramesInThePublishedLineCloud) {
  ASSERT_EQ(demo_->exit_code, 0) << demo_->err;
  const test::CliResult r = test::RunLcv(
      "localize --map " + Out("desk_line_cloud.lcmap") + " --dataset " + Out("desk") +
          " --sequence client --frames 0::8 --max-position-error 0.05 --max-rotation-error 1"
          " --trajectory-out " + dir_ + "/p6l.txt --stats-out " + dir_ + "/p6l.json",
      dir_);
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  std::ifstream in(dir_ + "/p6l.json");
  const nlohmann::json stats = nlohmann::json::parse(in);
  EXPECT_EQ(stats.at("frames").get<int>(), 5);
  EXPECT_GE(stats.at("ground_truth").at("success_rate").get<double>(), 0.8) << stats.dump(1);
  EXPECT_LT(stats.at("ground_truth").at("median_position_error").get<double>(), 0.05);
  EXPECT_TRUE(fs::exists(dir_ + "/p6l.txt"));
  // Usage errors name the option.
  const test::CliResult bad = test::RunLcv(
      "localize --map " + Out("desk_line_cloud.lcmap") + " --dataset " + Out("desk") +
          " --frames x --trajectory-out " + dir_ + "/x.txt",
      dir_);
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("--frames"), std::string::npos) << bad.err;
}

}  // namespace
}  // namespace lcv
