// `lcv eval ape|rpe` and `lcv dataset info` through the built binary: exit codes, JSON output,
// error messages.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "mapping/io/trajectory.h"
#include "slam/geometry/sim3.h"
#include "slam/geometry/so3.h"

#include "tests/support/cli_run.h"

namespace lcv {
namespace {

namespace fs = std::filesystem;

using RunResult = test::CliResult;

class EvalCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lcv_eval_cli_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Path(const std::string& name) const { return (dir_ / name).string(); }

  static std::string Slurp(const std::string& path) {
    std::ifstream in(path);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  }

  RunResult Run(const std::string& arguments) const { return test::RunLcv(arguments, dir_.string()); }

  static nlohmann::json Json(const RunResult& r) {
    try {
      return nlohmann::json::parse(r.out);
    } catch (const std::exception& e) {
      ADD_FAILURE() << "not JSON: " << r.out << "\nstderr: " << r.err;
      return nlohmann::json::object();
    }
  }

  // A ground-truth helix and an estimate = est_from_gt * gt + noise, both TUM.
  void WriteTrajectories(double noise_sigma, std::uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> noise(0.0, noise_sigma);
    const slam::Sim3d est_from_gt(0.25, slam::ExpSO3(Eigen::Vector3d(0.2, 0.5, -1.0)),
                                  Eigen::Vector3d(1, 2, 3));
    mapping::Trajectory gt, est;
    for (int i = 0; i < 60; ++i) {
      const double a = 0.15 * i;
      const slam::Rigid3d world_from_cam(slam::ExpSO3(Eigen::Vector3d(0.05 * i, a, 0.1)),
                                         Eigen::Vector3d(4 * std::cos(a), 4 * std::sin(a), 0.2 * i));
      gt.poses.push_back({100.0 + 0.1 * i, world_from_cam.Inverse()});
      const slam::Rigid3d est_world_from_cam(
          est_from_gt.rotation * world_from_cam.rotation,
          est_from_gt * world_from_cam.translation +
              Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
      est.poses.push_back({100.0 + 0.1 * i + 0.003, est_world_from_cam.Inverse()});
    }
    mapping::WriteTrajectory(gt, Path("gt.txt"), mapping::TrajectoryFormat::kTum);
    mapping::WriteTrajectory(est, Path("est.txt"), mapping::TrajectoryFormat::kTum);
    mapping::WriteTrajectory(gt, Path("gt_kitti.txt"), mapping::TrajectoryFormat::kKitti);
  }

  fs::path dir_;
};

TEST_F(EvalCliTest, HelpAndUsageErrors) {
  RunResult r = Run("eval ape --help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("--align"), std::string::npos);
  EXPECT_NE(r.out.find("default: none"), std::string::npos);
  EXPECT_NE(r.out.find("example"), std::string::npos);
  EXPECT_EQ(Run("eval rpe --help").exit_code, 0);
  EXPECT_EQ(Run("dataset info --help").exit_code, 0);

  WriteTrajectories(0.0, 1);
  r = Run("eval ape --gt " + Path("gt.txt") + " --est " + Path("est.txt") + " --align sim4");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("sim4"), std::string::npos) << r.err;
  EXPECT_EQ(Run("eval ape --gt " + Path("gt.txt")).exit_code, 2);
  // KITTI (no timestamps) against TUM without --times.
  r = Run("eval ape --gt " + Path("gt_kitti.txt") + " --est " + Path("est.txt"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--times"), std::string::npos) << r.err;
  // A missing file is a runtime failure naming the file.
  r = Run("eval ape --gt " + Path("nope.txt") + " --est " + Path("est.txt"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("nope.txt"), std::string::npos) << r.err;
}

TEST_F(EvalCliTest, ApeJsonAfterSim3AlignmentRecoversScale) {
  WriteTrajectories(0.002, 2);
  RunResult r = Run("eval ape --gt " + Path("gt.txt") + " --est " + Path("est.txt") +
                    " --align sim3 --json --errors-out " + Path("errors.csv"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = Json(r);
  for (const char* key : {"rmse", "mean", "median", "std", "min", "max", "rot_mean_deg", "matched"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  EXPECT_EQ(j["matched"], 60);
  EXPECT_NEAR(j["scale"].get<double>(), 4.0, 0.01);
  // 0.002 noise per axis in estimate units is 0.008 in gt units: rmse ~ 0.014.
  EXPECT_LT(j["rmse"].get<double>(), 0.03);
  EXPECT_GT(j["rmse"].get<double>(), 0.005);
  EXPECT_LT(j["rot_mean_deg"].get<double>(), 0.1);  // only the alignment rotation error
  const std::string csv = Slurp(Path("errors.csv"));
  EXPECT_EQ(csv.rfind("index,timestamp,translation_error_m,rotation_error_deg\n", 0), 0u);
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 61);

  // Without alignment the error is large, and --max-rmse turns it into exit code 3.
  r = Run("eval ape --gt " + Path("gt.txt") + " --est " + Path("est.txt") + " --max-rmse 0.1");
  EXPECT_EQ(r.exit_code, 3) << r.out << r.err;
  EXPECT_NE(r.out.find("APE"), std::string::npos);
  EXPECT_LE(std::count(r.out.begin(), r.out.end(), '\n'), 10);
  // SE(3) cannot fix the scale.
  r = Run("eval ape --gt " + Path("gt.txt") + " --est " + Path("est.txt") + " --align se3 --json");
  EXPECT_GT(Json(r)["rmse"].get<double>(), 1.0);
}

// On a nearly straight path the centres' alignment is noted as unable to pin the rotation about
// it; --align-orientations takes that rotation from the cameras and needs an alignment; the helix
// of the other tests spreads enough for no note.
TEST_F(EvalCliTest, StraightPathsAreNotedAndAlignOrientationsNeedsAnAlignment) {
  mapping::Trajectory gt, est;
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 0.02);
  for (int i = 0; i < 40; ++i) {
    const slam::Rigid3d world_from_cam(slam::ExpSO3(Eigen::Vector3d(0, 0.01 * i, 0)),
                                       Eigen::Vector3d(1.5 * i, 0.05 * std::sin(0.3 * i), 1.6));
    gt.poses.push_back({0.1 * i, world_from_cam.Inverse()});
    const slam::Rigid3d noisy(world_from_cam.rotation,
                              world_from_cam.translation +
                                  Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
    est.poses.push_back({0.1 * i, noisy.Inverse()});
  }
  mapping::WriteTrajectory(gt, Path("street_gt.txt"), mapping::TrajectoryFormat::kTum);
  mapping::WriteTrajectory(est, Path("street_est.txt"), mapping::TrajectoryFormat::kTum);
  const std::string files = " --gt " + Path("street_gt.txt") + " --est " + Path("street_est.txt");
  RunResult r = Run("eval ape" + files + " --align sim3 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("nearly on a line"), std::string::npos) << r.err;
  EXPECT_LT(Json(r)["centre_spread_ratio"].get<double>(), 0.05);
  EXPECT_FALSE(Json(r)["align_orientations"].get<bool>());
  r = Run("eval ape" + files + " --align sim3 --align-orientations --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err.find("nearly on a line"), std::string::npos) << r.err;
  EXPECT_TRUE(Json(r)["align_orientations"].get<bool>());
  EXPECT_LT(Json(r)["rot_max_deg"].get<double>(), 1e-6);  // the orientations are exact
  r = Run("eval ape" + files + " --align-orientations");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--align se3 or sim3"), std::string::npos) << r.err;
  WriteTrajectories(0.002, 2);
  r = Run("eval ape --gt " + Path("gt.txt") + " --est " + Path("est.txt") + " --align sim3");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err.find("nearly on a line"), std::string::npos) << r.err;
}

TEST_F(EvalCliTest, PlotIsAPngOfTheRequestedSizeAndBadPlotOptionsAreRefused) {
  WriteTrajectories(0.01, 4);
  RunResult r = Run("eval ape --gt " + Path("gt.txt") + " --est " + Path("est.txt") +
                    " --align sim3 --plot " + Path("ape.png") + " --plot-size 640x480");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const cv::Mat image = cv::imread(Path("ape.png"), cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty());
  EXPECT_EQ(image.cols, 640);
  EXPECT_EQ(image.rows, 480);
  // Not blank: the trajectories and the colour bar are drawn.
  cv::Mat grey;
  cv::extractChannel(image, grey, 1);
  EXPECT_GT(cv::countNonZero(grey < 200), 1000);
  r = Run("eval rpe --gt " + Path("gt.txt") + " --est " + Path("est.txt") +
          " --align sim3 --delta 5 --plot " + Path("rpe.png") + " --plot-axes xz");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_FALSE(cv::imread(Path("rpe.png")).empty());

  // Refused before any work: the files are not written.
  r = Run("eval ape --gt " + Path("gt.txt") + " --est " + Path("est.txt") + " --plot " +
          Path("bad.png") + " --plot-axes xx");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--plot-axes"), std::string::npos) << r.err;
  r = Run("eval ape --gt " + Path("gt.txt") + " --est " + Path("est.txt") + " --plot " +
          Path("bad.png") + " --plot-size 100x100");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--plot-size"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(Path("bad.png")));
  r = Run("eval ape --gt " + Path("gt.txt") + " --est " + Path("est.txt") + " --plot " +
          Path("no_such_folder/p.png"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("no_such_folder"), std::string::npos) << r.err;
}

TEST_F(EvalCliTest, RpeJsonWithDelta) {
  WriteTrajectories(0.0, 3);
  const RunResult r = Run("eval rpe --gt " + Path("gt.txt") + " --est " + Path("est.txt") +
                          " --align sim3 --delta 5 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = Json(r);
  EXPECT_EQ(j["matched"], 60);
  EXPECT_EQ(j["count"], 11);  // pairs (0,5) ... (50,55)
  EXPECT_LT(j["rmse"].get<double>(), 1e-9);
  // Without Sim(3) the relative translations are 4 times too short.
  const RunResult unaligned =
      Run("eval rpe --gt " + Path("gt.txt") + " --est " + Path("est.txt") + " --json");
  EXPECT_GT(Json(unaligned)["rmse"].get<double>(), 0.1);
}

TEST_F(EvalCliTest, Kitti00GroundTruthAgainstItselfAndDatasetInfo) {
  const std::string kitti = std::string(LCV_SHARED_DIR) + "/data/kitti00";
  if (!fs::exists(kitti + "/poses.txt")) GTEST_SKIP() << kitti << " not found (shared KITTI data absent)";
  RunResult r = Run("eval ape --gt " + kitti + "/poses.txt --est " + kitti +
                    "/poses.txt --align se3 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(Json(r)["matched"], 160);
  EXPECT_LT(Json(r)["max"].get<double>(), 1e-9);

  // The client half's ground truth, exported by `dataset info`, evaluated with KITTI times.
  r = Run("dataset info " + kitti + " --frames 0::2 --json --write-gt " + Path("even.txt"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json info = Json(r);
  EXPECT_EQ(info["format"], "kitti");
  EXPECT_EQ(info["frames"], 80);
  EXPECT_EQ(info["camera"]["cols"], 1241);
  EXPECT_EQ(info["ground_truth"], true);
  r = Run("eval ape --gt " + kitti + "/poses.txt --times " + kitti + "/times.txt --est " +
          Path("even.txt") + " --align sim3 --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(Json(r)["matched"], 80);
  EXPECT_LT(Json(r)["rmse"].get<double>(), 1e-9);
  EXPECT_NEAR(Json(r)["scale"].get<double>(), 1.0, 1e-9);

  r = Run("dataset info " + kitti + " --frames 1:2:0");
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("step"), std::string::npos) << r.err;
  r = Run("dataset info " + Path("nowhere"));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("nowhere"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace lcv
