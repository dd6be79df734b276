#include "privacy/audit.h"

#include <algorithm>
#include <fstream>

#include <gtest/gtest.h>

#include "mapping/line_cloud.h"
#include "slam/util/error.h"
#include "tests/privacy/line_cloud_fixture.h"

namespace lcv::privacy {
namespace {

TEST(FailRules, ParsesStrictly) {
  const auto rules = ParseFailRules("density@0.1m=0.05,visibility@2%=0.1");
  ASSERT_EQ(rules.size(), 2u);
  EXPECT_EQ(rules[0].attack, "density");
  EXPECT_FALSE(rules[0].tolerance.relative);
  EXPECT_DOUBLE_EQ(rules[0].tolerance.value, 0.1);
  EXPECT_DOUBLE_EQ(rules[0].max_fraction, 0.05);
  EXPECT_TRUE(rules[1].tolerance.relative);
  EXPECT_DOUBLE_EQ(rules[1].tolerance.value, 0.02);
  for (const char* bad : {"", "density", "density@0.1=0.05", "densty@0.1m=0.05", "density@-1m=0.1",
                          "density@0.1m=1.5", "density@0.1m=0.05,", "density@0.1m=0.05x",
                          "density@xm=0.1", "density =0.1"}) {
    EXPECT_THROW(ParseFailRules(bad), InputError) << bad;
  }
}

TEST(Audit, CleanLineCloudPassesAndReportHasTheIssueFields) {
  const std::uint64_t seed = 61;
  const slam::Map points = testing::MakeStreetPointMap(3000, seed);
  const slam::Map lines = testing::MakeLineCloud(points, seed);
  AuditInputs inputs;
  inputs.map = &lines;
  inputs.reference = &points;
  AuditOptions options;
  options.fail_rules = ParseFailRules("density@0.1m=0.9,visibility@3%=1");
  AuditReport report = RunAudit(inputs, options);
  EXPECT_TRUE(report.passed) << AuditSummary(report);
  const std::string path = ::testing::TempDir() + "/audit_clean.json";
  WriteAuditReport(&report, path);
  std::ifstream in(path);
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_TRUE(j.at("passed").get<bool>());
  std::vector<std::string> names;
  for (const auto& c : j.at("checks")) {
    names.push_back(c.at("name"));
    EXPECT_TRUE(c.contains("passed"));
    EXPECT_TRUE(c.contains("details"));
  }
  EXPECT_EQ(names, (std::vector<std::string>{"format", "directions", "concealed", "duplicates",
                                             "thresholds"}));
  ASSERT_EQ(j.at("attacks").size(), 4u);  // duplicate, density, visibility, information
  for (const auto& a : j.at("attacks")) {
    EXPECT_TRUE(a.at("recovered").contains("0.1m"));
    EXPECT_TRUE(a.at("recovered").contains("3%"));  // added by the rule
    EXPECT_TRUE(a.contains("median_error_m"));
    const std::string risk_file = a.at("risk_file");
    EXPECT_EQ(risk_file, "audit_clean." + a.at("name").get<std::string>() + "-risk.csv");
    std::ifstream risk(::testing::TempDir() + "/" + risk_file);
    std::string header;
    std::getline(risk, header);
    EXPECT_EQ(header, "line_id,risk");
  }
  const std::string summary = AuditSummary(report);
  EXPECT_LE(std::count(summary.begin(), summary.end(), '\n'), 10);
}

// A client's map with X' on 40 lines, 30 of them on their hidden point (1 cm off) and 10 slid
// 3 m along the line (a keypoint associated with the wrong point of the line): the audit reports
// them as the "client" attack, with 30 of 40 within 5 cm and the 40 estimates' median error.
TEST(Audit, ReportsTheClientsRestoredPointsAgainstTheHiddenPoints) {
  const std::uint64_t seed = 62;
  const slam::Map points = testing::MakeStreetPointMap(2000, seed);
  const slam::Map lines = testing::MakeLineCloud(points, seed);
  slam::Map client = lines;
  int k = 0;
  for (auto& [id, line] : client.lines) {
    const auto hidden = points.points.find(id);
    if (hidden == points.points.end()) continue;
    const Eigen::Vector3d across = line.line.direction.unitOrthogonal();
    if (k < 30) {
      line.restored_point = hidden->second.position + 0.01 * across;
    } else {
      line.restored_point = hidden->second.position + 3.0 * line.line.direction;
    }
    if (++k == 40) break;
  }
  ASSERT_EQ(k, 40);
  AuditInputs inputs;
  inputs.map = &lines;
  inputs.client = &client;
  inputs.reference = &points;
  AuditOptions options;
  options.run_density = options.run_visibility = options.run_information = false;
  const AuditReport report = RunAudit(inputs, options);
  const AttackOutcome* restored = nullptr;
  for (const AttackOutcome& a : report.attacks) {
    if (a.result.name == "client") restored = &a;
  }
  ASSERT_NE(restored, nullptr);
  EXPECT_EQ(restored->num_estimated, 40);
  ASSERT_TRUE(restored->recovery.has_value());
  const RecoveryStats& r = *restored->recovery;
  ASSERT_EQ(r.tolerances[0], (Tolerance{0.05, false}));
  EXPECT_NEAR(r.precision[0], 0.75, 1e-12);
  EXPECT_NEAR(r.fractions[0], 30.0 / r.num_hidden_points, 1e-12);
  EXPECT_NEAR(r.median_estimate_error_m, 0.01, 1e-9);
  const nlohmann::json j = AuditReportToJson(report);
  bool found = false;
  for (const auto& a : j.at("attacks")) {
    if (a.at("name") != "client") continue;
    found = true;
    EXPECT_NEAR(a.at("precision").at("0.05m").get<double>(), 0.75, 1e-12);
    EXPECT_NEAR(a.at("median_estimate_error_m").get<double>(), 0.01, 1e-9);
  }
  EXPECT_TRUE(found);
  EXPECT_NE(AuditSummary(report).find("40 restored points X'"), std::string::npos)
      << AuditSummary(report);

  // Without a reference the entry stays, without precision.
  inputs.reference = nullptr;
  const AuditReport unreferenced = RunAudit(inputs, options);
  EXPECT_NE(AuditSummary(unreferenced).find("40 restored points X' (their precision needs --reference)"),
            std::string::npos)
      << AuditSummary(unreferenced);
  inputs.reference = &points;

  // A client map without X' adds no client attack.
  inputs.client = &lines;
  for (const AttackOutcome& a : RunAudit(inputs, options).attacks) EXPECT_NE(a.result.name, "client");
}

// A line cloud whose Omega_L is eq. (1) of an isotropic covariance sized by the distance from
// the first observing keyframe (what `lcv slam` writes) fails an information rule; the same
// points published with the default rule pass it.
TEST(Audit, InformationRuleCatchesCovarianceSizedLines) {
  slam::Map points = testing::MakeStreetPointMap(1500, 64);
  const double pixel_angle = 1.0 / points.cameras.begin()->second.fx;
  for (auto& [id, p] : points.points) {
    const Eigen::Vector3d centre =
        points.keyframes.at(p.observations.front().keyframe_id).cam_from_world.Center();
    const double sigma = pixel_angle * (p.position - centre).norm();
    p.covariance = sigma * sigma * Eigen::Matrix3d::Identity();
  }
  AuditOptions options;
  options.run_density = false;
  options.run_visibility = false;
  options.fail_rules = ParseFailRules("information@1%=0.05");
  for (auto rule : {mapping::LineInformationRule::kPointCovariance,
                    mapping::LineInformationRule::kProxyPoint}) {
    mapping::LineCloudOptions convert;
    convert.seed = 64;
    convert.information = rule;
    const slam::Map lines = mapping::ConvertToLineCloud(points, convert);
    AuditInputs inputs;
    inputs.map = &lines;
    inputs.reference = &points;
    const AuditReport report = RunAudit(inputs, options);
    EXPECT_EQ(report.passed, rule == mapping::LineInformationRule::kProxyPoint)
        << AuditSummary(report);
  }
}

TEST(Audit, ThresholdAndLeaksFail) {
  const slam::Map points = testing::MakeStreetPointMap(2000, 62);
  slam::Map lines = testing::MakeLineCloud(points, 62);
  AuditInputs inputs;
  inputs.map = &lines;
  inputs.reference = &points;
  AuditOptions options;
  options.run_visibility = false;
  options.fail_rules = ParseFailRules("density@5%=0.01");
  const AuditReport strict = RunAudit(inputs, options);
  EXPECT_FALSE(strict.passed);
  EXPECT_FALSE(strict.checks.back().passed);
  EXPECT_TRUE(strict.checks[0].passed);

  lines.lines.begin()->second.restored_point = points.points.begin()->second.position;
  options.fail_rules.clear();
  options.run_density = false;
  const AuditReport leak = RunAudit(inputs, options);
  EXPECT_FALSE(leak.passed);
  EXPECT_FALSE(leak.checks[0].passed);
}

}  // namespace
}  // namespace lcv::privacy
