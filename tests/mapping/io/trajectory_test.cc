#include "mapping/io/trajectory.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "slam/geometry/so3.h"
#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

namespace fs = std::filesystem;

class TrajectoryFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lcv_trajectory_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Write(const std::string& name, const std::string& text) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path) << text;
    return path;
  }

  // Expects reading to fail with a message containing the path and every fragment.
  void ExpectError(const std::string& text, TrajectoryFormat format,
                   std::initializer_list<std::string> fragments) {
    const std::string path = Write("bad.txt", text);
    try {
      ReadTrajectory(path, format);
      ADD_FAILURE() << "no error for:\n" << text;
    } catch (const InputError& e) {
      const std::string message = e.what();
      EXPECT_EQ(message.rfind(path + ": ", 0), 0u) << message;
      for (const auto& f : fragments) EXPECT_NE(message.find(f), std::string::npos) << message;
    }
  }

  fs::path dir_;
};

Trajectory RandomTrajectory(int count, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  Trajectory trajectory;
  double t = 1305031102.175304;
  for (int i = 0; i < count; ++i) {
    t += 0.033 + 0.001 * std::abs(normal(rng));
    const Eigen::Vector3d omega(normal(rng), normal(rng), normal(rng));
    const Eigen::Vector3d centre(10 * normal(rng), 10 * normal(rng), normal(rng));
    const slam::Rigid3d world_from_cam(slam::ExpSO3(omega), centre);
    trajectory.poses.push_back({t, world_from_cam.Inverse()});
  }
  return trajectory;
}

void ExpectSameTrajectory(const Trajectory& a, const Trajectory& b, double tolerance,
                          bool compare_timestamps) {
  ASSERT_EQ(a.poses.size(), b.poses.size());
  for (size_t i = 0; i < a.poses.size(); ++i) {
    if (compare_timestamps) {
      EXPECT_EQ(a.poses[i].timestamp, b.poses[i].timestamp) << i;
    }
    EXPECT_LT(slam::AngularDistance(a.poses[i].cam_from_world.rotation,
                                    b.poses[i].cam_from_world.rotation),
              tolerance)
        << i;
    EXPECT_LT((a.poses[i].cam_from_world.Center() - b.poses[i].cam_from_world.Center()).norm(),
              tolerance * 100)
        << i;
  }
}

TEST_F(TrajectoryFileTest, TumRoundTrip) {
  const Trajectory original = RandomTrajectory(50, 7);
  const std::string path = (dir_ / "traj.tum").string();
  WriteTrajectory(original, path, TrajectoryFormat::kTum);
  EXPECT_EQ(DetectTrajectoryFormat(path), TrajectoryFormat::kTum);
  const Trajectory read = ReadTrajectory(path, TrajectoryFormat::kTum);
  EXPECT_TRUE(read.has_timestamps);
  ExpectSameTrajectory(original, read, 1e-12, true);
}

TEST_F(TrajectoryFileTest, KittiRoundTripAndTimesFile) {
  const Trajectory original = RandomTrajectory(30, 8);
  const std::string path = (dir_ / "poses.txt").string();
  WriteTrajectory(original, path, TrajectoryFormat::kKitti);
  EXPECT_EQ(DetectTrajectoryFormat(path), TrajectoryFormat::kKitti);
  Trajectory read = ReadTrajectory(path, TrajectoryFormat::kKitti);
  EXPECT_FALSE(read.has_timestamps);
  for (size_t i = 0; i < read.poses.size(); ++i) EXPECT_EQ(read.poses[i].timestamp, double(i));
  ExpectSameTrajectory(original, read, 1e-12, false);

  std::string times_text;
  for (const auto& pose : original.poses) times_text += std::to_string(pose.timestamp) + "\n";
  const std::string times_path = Write("times.txt", times_text);
  const std::vector<double> times = ReadTimesFile(times_path);
  ASSERT_EQ(times.size(), original.poses.size());
  AssignTimestamps(times, times_path, &read);
  EXPECT_TRUE(read.has_timestamps);
  EXPECT_EQ(read.poses[3].timestamp, times[3]);
  std::vector<double> too_few(times.begin(), times.end() - 1);
  EXPECT_THROW(AssignTimestamps(too_few, times_path, &read), InputError);
}

TEST_F(TrajectoryFileTest, ReadsCommentsBlankLinesAndKnownValues) {
  // A camera 2 m along x, rotated 90 degrees about z (qz = qw = sqrt(1/2)).
  const std::string path = Write("t.txt",
                                 "# timestamp tx ty tz qx qy qz qw\n\n"
                                 "1.5 2 0 0 0 0 0.7071067811865476 0.7071067811865476\n"
                                 "1.6,2,0,0,0,0,0,1\r\n");
  const Trajectory t = ReadTrajectory(path, TrajectoryFormat::kTum);
  ASSERT_EQ(t.poses.size(), 2u);
  EXPECT_EQ(t.poses[0].timestamp, 1.5);
  EXPECT_TRUE(t.poses[0].cam_from_world.Center().isApprox(Eigen::Vector3d(2, 0, 0), 1e-12));
  // The camera's x axis points along world y.
  const Eigen::Vector3d x_axis_in_world =
      t.poses[0].cam_from_world.Inverse().rotation * Eigen::Vector3d::UnitX();
  EXPECT_TRUE(x_axis_in_world.isApprox(Eigen::Vector3d::UnitY(), 1e-12));
}

TEST_F(TrajectoryFileTest, BadInputNamesFileLineAndProblem) {
  ExpectError("0 1 2 3 0 0 0 1\n1 1 2 3 0 0 1\n", TrajectoryFormat::kTum,
              {"line 2", "expected 8 numbers", "got 7"});
  ExpectError("0 1 2 3 0 0 0 1\n1 1 2 x 0 0 0 1\n", TrajectoryFormat::kTum,
              {"line 2", "'x'", "not a finite number"});
  ExpectError("0 1 2 3 0 0 0 1\n0 1 2 3 0 0 0 1\n", TrajectoryFormat::kTum,
              {"line 2", "not greater"});
  ExpectError("0 1 2 3 0 0 0 2\n", TrajectoryFormat::kTum, {"line 1", "norm 2"});
  ExpectError("0 1 2 3 0 0 0 nan\n", TrajectoryFormat::kTum, {"line 1", "nan"});
  ExpectError("# nothing\n", TrajectoryFormat::kTum, {"no poses"});
  ExpectError("1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n", TrajectoryFormat::kKitti,
              {"line 2", "expected 12 numbers", "got 11"});
  ExpectError("2 0 0 0 0 1 0 0 0 0 1 0\n", TrajectoryFormat::kKitti, {"line 1", "not a rotation"});
  ExpectError("-1 0 0 0 0 1 0 0 0 0 1 0\n", TrajectoryFormat::kKitti, {"line 1", "not a rotation"});

  const std::string odd = Write("odd.txt", "1 2 3\n");
  EXPECT_THROW(DetectTrajectoryFormat(odd), InputError);
  const std::string times = Write("times.txt", "0\n0.1\n0.05\n");
  EXPECT_THROW(ReadTimesFile(times), InputError);
  EXPECT_THROW(ReadTrajectory((dir_ / "missing.txt").string(), TrajectoryFormat::kTum), InputError);
}

TEST(TrajectoryFormatTest, Names) {
  EXPECT_EQ(ParseTrajectoryFormat("tum"), TrajectoryFormat::kTum);
  EXPECT_EQ(ParseTrajectoryFormat("kitti"), TrajectoryFormat::kKitti);
  EXPECT_FALSE(ParseTrajectoryFormat("euroc"));
  EXPECT_STREQ(TrajectoryFormatName(TrajectoryFormat::kKitti), "kitti");
}

TEST(TrajectoryKitti00Test, ReadsSharedGroundTruth) {
  const std::string dir = std::string(LCV_SHARED_DIR) + "/data/kitti00";
  if (!fs::exists(dir + "/poses.txt")) GTEST_SKIP() << dir << " not found (shared KITTI data absent)";
  Trajectory gt = ReadTrajectory(dir + "/poses.txt", TrajectoryFormat::kKitti);
  ASSERT_EQ(gt.poses.size(), 160u);
  EXPECT_LT(gt.poses[0].cam_from_world.Center().norm(), 1e-9);
  // Frame 1 (second line): centre (-0.04690294, -0.02839928, 0.8586941).
  EXPECT_TRUE(gt.poses[1].cam_from_world.Center().isApprox(
      Eigen::Vector3d(-0.04690294, -0.02839928, 0.8586941), 1e-9));
  AssignTimestamps(ReadTimesFile(dir + "/times.txt"), dir + "/times.txt", &gt);
  EXPECT_NEAR(gt.poses[1].timestamp, 0.1037359, 1e-12);
}

}  // namespace
}  // namespace lcv::mapping
