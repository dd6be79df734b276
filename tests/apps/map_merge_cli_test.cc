// `lcv map merge|optimize|publish` through the built binary: reports, skipped uploads, atomic
// output.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "mapping/io/map_file.h"
#include "mapping/line_cloud.h"
#include "mapping/synthetic_map.h"
#include "privacy/map_alignment.h"
#include "slam/geometry/so3.h"
#include "tests/support/cli_run.h"

namespace lcv {
namespace {

namespace fs = std::filesystem;

class MapMergeCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lcv_map_merge_cli_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    mapping::SyntheticMapOptions o;
    o.num_points = 800;
    o.num_keyframes = 16;
    o.max_depth_m = 25.0;
    o.seed = 5;
    scene_ = mapping::MakeSyntheticPointMap(o);
    mapping::WriteMap(mapping::ConvertToLineCloud(scene_, {1}), Path("base.lcmap"));
    // An independent session of the same street: ids of its own, another frame and scale.
    slam::Map session;
    session.cameras = scene_.cameras;
    const slam::Id offset = 100000;
    for (const auto& [id, kf] : scene_.keyframes) {
      slam::Keyframe k = kf;
      k.id += offset;
      session.keyframes[k.id] = k;
    }
    for (const auto& [id, p] : scene_.points) {
      slam::PointLandmark q = p;
      q.id += offset;
      for (auto& obs : q.observations) obs.keyframe_id += offset;
      session.points[q.id] = q;
    }
    const slam::Sim3d S(0.5, slam::ExpSO3(Eigen::Vector3d(0.1, -0.4, 0.2)),
                        Eigen::Vector3d(1, 2, 3));
    mapping::WriteMap(mapping::ConvertToLineCloud(privacy::TransformMap(session, S), {2}),
                      Path("upload.lcmap"));
    std::ofstream(Path("corrupt.lcmap")) << "not a map";
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  test::CliResult Run(const std::string& arguments) const {
    return test::RunLcv(arguments, dir_.string());
  }
  // The verdict of one attack in a publish report round.
  static nlohmann::json Verdict(const nlohmann::json& round, const std::string& attack) {
    for (const auto& a : round["attacks"]) {
      if (a["name"] == attack) return a["passed"];
    }
    return nullptr;
  }
  static nlohmann::json ReadJson(const std::string& path) {
    std::ifstream in(path);
    return nlohmann::json::parse(in);
  }

  fs::path dir_;
  slam::Map scene_;
};

TEST_F(MapMergeCliTest, MergesAGoodUploadAndReportsACorruptOneInOrder) {
  const auto r = Run("map merge " + Path("base.lcmap") + " " + Path("corrupt.lcmap") + " " +
                     Path("upload.lcmap") + " --out " + Path("merged.lcmap") + " --report " +
                     Path("merge.json") + " --optimize");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("[1/2]"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("[2/2]"), std::string::npos) << r.err;
  const nlohmann::json report = ReadJson(Path("merge.json"));
  ASSERT_EQ(report["uploads"].size(), 2u);
  EXPECT_FALSE(report["uploads"][0]["accepted"].get<bool>());
  EXPECT_NE(report["uploads"][0]["reason"].get<std::string>().find("unreadable"),
            std::string::npos);
  EXPECT_TRUE(report["uploads"][1]["accepted"].get<bool>()) << report.dump(2);
  EXPECT_NEAR(report["uploads"][1]["sim3"]["scale"].get<double>(), 2.0, 0.02);
  EXPECT_GT(report["uploads"][1]["lines_merged"].get<int>(), 600);
  for (const char* key : {"lines_added", "lines_merged", "lines_dropped"}) {
    EXPECT_TRUE(report["uploads"][1].contains(key)) << key;
  }
  EXPECT_TRUE(report["cost_before"].is_number());
  EXPECT_TRUE(report["cost_after"].is_number());
  EXPECT_TRUE(report["seconds"].is_number());
  const slam::Map merged = mapping::ReadMap(Path("merged.lcmap"));
  EXPECT_TRUE(slam::IsPublishedLineCloud(merged));
  EXPECT_EQ(merged.server_keyframes.size(), 2 * scene_.keyframes.size());
  // Every point of the street is published once.
  EXPECT_LT(merged.lines.size(), scene_.points.size() * 1.05);

  // The optimizer on its own output.
  const auto o = Run("map optimize " + Path("merged.lcmap") + " --out " + Path("opt.lcmap") +
                     " --report " + Path("opt.json"));
  ASSERT_EQ(o.exit_code, 0) << o.err;
  EXPECT_TRUE(ReadJson(Path("opt.json"))["success"].get<bool>());
}

TEST_F(MapMergeCliTest, NothingIsWrittenWhenTheMergeFails) {
  // Unreadable base: exit 1, no output, no report.
  auto r = Run("map merge " + Path("corrupt.lcmap") + " " + Path("upload.lcmap") + " --out " +
               Path("merged.lcmap") + " --report " + Path("merge.json"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("corrupt.lcmap"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(Path("merged.lcmap")));
  EXPECT_FALSE(fs::exists(Path("merge.json")));
  // Output folder missing: exit 1, and nothing left beside it.
  r = Run("map merge " + Path("base.lcmap") + " " + Path("upload.lcmap") + " --out " +
          Path("missing/merged.lcmap") + " --report " + Path("merge.json"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_FALSE(fs::exists(Path("merge.json")));
  // No upload: usage error.
  r = Run("map merge " + Path("base.lcmap") + " --out " + Path("merged.lcmap"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(Run("map merge --help").exit_code, 0);
  EXPECT_EQ(Run("map optimize --help").exit_code, 0);
}

TEST_F(MapMergeCliTest, PublishGateWritesOnlyWhatPassesTheLimits) {
  mapping::WriteMap(scene_, Path("points.lcmap"));
  // Limits the raw conversion meets: published at round 0, nothing dropped.
  auto r = Run("map publish " + Path("points.lcmap") + " --out " + Path("pub.lcmap") +
               " --report " + Path("pub.json") +
               " --fail-on density@0.1m=1,visibility@0.1m=1,duplicate@0.1m=1");
  ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
  nlohmann::json report = ReadJson(Path("pub.json"));
  EXPECT_TRUE(report["passed"].get<bool>());
  EXPECT_EQ(report["lines_removed"].get<int>(), 0);
  EXPECT_EQ(report["rounds"].size(), 1u);
  EXPECT_EQ(Verdict(report["rounds"][0], "density"), true);
  EXPECT_EQ(Verdict(report["rounds"][0], "visibility"), true);
  EXPECT_TRUE(slam::IsPublishedLineCloud(mapping::ReadMap(Path("pub.lcmap"))));
  // Limits nothing meets, no budget to drop lines: not published, exit 3, the reason reported.
  r = Run("map publish " + Path("points.lcmap") + " --out " + Path("strict.lcmap") +
          " --report " + Path("strict.json") + " --fail-on density@5%=0 --max-drop 0");
  EXPECT_EQ(r.exit_code, 3) << r.err << r.out;
  EXPECT_FALSE(fs::exists(Path("strict.lcmap")));
  report = ReadJson(Path("strict.json"));
  EXPECT_FALSE(report["passed"].get<bool>());
  EXPECT_TRUE(report["reason"].is_string());
  EXPECT_EQ(Verdict(report["rounds"][0], "density"), false);
  EXPECT_EQ(Verdict(report["rounds"][0], "visibility"), nullptr);  // no rule names it
  // With a budget, the riskiest lines are dropped round by round and the report says so.
  r = Run("map publish " + Path("points.lcmap") + " --out " + Path("mid.lcmap") + " --report " +
          Path("mid.json") + " --fail-on density@5%=0 --max-drop 0.3 --step 0.15");
  report = ReadJson(Path("mid.json"));
  EXPECT_GE(report["rounds"].size(), 2u);
  EXPECT_GT(report["lines_removed"].get<int>(), 0);
  // Default order: recovered lines first, never more than --step per round, coverage reported.
  EXPECT_EQ(report["order"], "recovered");
  const int converted = report["converted_lines"].get<int>();
  for (const auto& round : report["rounds"]) {
    if (round.contains("lines_dropped")) {
      EXPECT_LE(round["lines_dropped"].get<int>(), static_cast<int>(0.15 * converted) + 1);
    }
  }
  const auto& cost = report["estimated_localization_cost"];
  EXPECT_EQ(cost["min_keyframe_lines"], 24);
  EXPECT_GE(cost["coverage_after"]["fewest_lines_in_a_keyframe"].get<int>(),
            std::min(24, cost["coverage_before"]["fewest_lines_in_a_keyframe"].get<int>()));
  // The earlier mitigation stays selectable; a bad order is a usage error.
  r = Run("map publish " + Path("points.lcmap") + " --out " + Path("risk.lcmap") + " --report " +
          Path("risk.json") + " --fail-on density@5%=0 --max-drop 0.3 --step 0.15" +
          " --order risk --min-keyframe-lines 0");
  report = ReadJson(Path("risk.json"));
  EXPECT_EQ(report["order"], "risk");
  EXPECT_GT(report["lines_removed"].get<int>(), 0);
  EXPECT_EQ(Run("map publish " + Path("points.lcmap") + " --out " + Path("x.lcmap") +
                " --order sideways").exit_code, 2);
  // A limit the raw conversion fails (density recovers 17% within 1% of this street): both
  // orders meet it; dropping the recovered lines first needs fewer lines than the riskiest by
  // score (each dropped line removes its own recovered point; a risky line may not have been
  // recovered at all). Measured: 123 and 415 of 800.
  int removed[2] = {0, 0};
  for (int k = 0; k < 2; ++k) {
    const std::string name = k == 0 ? "recovered" : "risk";
    r = Run("map publish " + Path("points.lcmap") + " --out " + Path(name + ".lcmap") +
            " --report " + Path(name + ".json") + " --order " + name +
            " --fail-on density@1%=0.05,visibility@1%=0.25,duplicate@1%=0");
    ASSERT_EQ(r.exit_code, 0) << r.err << r.out;
    removed[k] = ReadJson(Path(name + ".json"))["lines_removed"].get<int>();
    // Every published line's Omega_L is the publishing rule's for the map as published (its
    // distance floor is a median over the lines kept), not for the map before the drops.
    const slam::Map published = mapping::ReadMap(Path(name + ".lcmap"));
    const double floor = mapping::ProxyDistanceFloor(published);
    for (const auto& [id, line] : published.lines) {
      ASSERT_LT((line.information - mapping::ProxyLineInformation(published, line, floor)).norm(),
                1e-9 * line.information.norm())
          << name << " line " << id;
    }
  }
  EXPECT_GT(removed[0], 0) << "set-up: the limit fails on the raw conversion";
  EXPECT_LT(removed[0], removed[1]);
  EXPECT_EQ(Run("map publish --help").exit_code, 0);
}

}  // namespace
}  // namespace lcv
