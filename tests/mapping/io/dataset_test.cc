#include "mapping/io/dataset.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "mapping/io/camera_file.h"
#include "slam/geometry/so3.h"
#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

namespace fs = std::filesystem;

constexpr int kCols = 32;
constexpr int kRows = 24;

// Builds small datasets of every layout in a temporary folder. Image i is uniform with
// intensity 10 * (i + 1), so that tests can tell which frame they got.
class DatasetTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("lcv_dataset_test_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_);
  }
  void TearDown() override { fs::remove_all(root_); }

  std::string Path(const std::string& relative) const { return (root_ / relative).string(); }

  void WriteText(const std::string& relative, const std::string& text) {
    fs::create_directories(fs::path(Path(relative)).parent_path());
    std::ofstream(Path(relative)) << text;
  }

  void WriteImage(const std::string& relative, int i, int cols = kCols, int rows = kRows) {
    fs::create_directories(fs::path(Path(relative)).parent_path());
    ASSERT_TRUE(cv::imwrite(Path(relative), cv::Mat(rows, cols, CV_8UC1, cv::Scalar(10 * (i + 1)))));
  }

  static std::string Name6(int i) {
    char name[32];
    std::snprintf(name, sizeof(name), "%06d.png", i);
    return name;
  }

  static slam::CameraParams SmallCamera() {
    slam::CameraParams camera;
    camera.name = "small";
    camera.fx = camera.fy = 30.0;
    camera.cx = 15.5;
    camera.cy = 11.5;
    camera.cols = kCols;
    camera.rows = kRows;
    camera.fps = 20.0;
    return camera;
  }

  // world_from_cam of frame i of the synthetic ground truth.
  static slam::Rigid3d Pose(int i) {
    return slam::Rigid3d(slam::ExpSO3(Eigen::Vector3d(0.01 * i, 0.02 * i, -0.01 * i)),
                         Eigen::Vector3d(0.5 * i, 0.1 * i, 1.0 + i));
  }

  static std::string KittiLine(const slam::Rigid3d& world_from_cam) {
    const Eigen::Matrix<double, 3, 4> m = world_from_cam.ToMatrix();
    std::string line;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) line += FormatDoubleExact(m(r, c)) + (r == 2 && c == 3 ? "\n" : " ");
    }
    return line;
  }

  static std::string TumLine(double t, const slam::Rigid3d& world_from_cam) {
    const auto& p = world_from_cam.translation;
    const auto& q = world_from_cam.rotation;
    std::string line = FormatDoubleExact(t);
    for (double v : {p.x(), p.y(), p.z(), q.x(), q.y(), q.z(), q.w()}) line += " " + FormatDoubleExact(v);
    return line + "\n";
  }

  // KITTI sequence with n frames in dir (relative).
  void MakeKitti(const std::string& dir, int n, bool with_poses = true) {
    std::string times, poses;
    for (int i = 0; i < n; ++i) {
      WriteImage(dir + "/image_0/" + Name6(i), i);
      times += FormatDoubleExact(0.1 * i + 0.003) + "\n";
      poses += KittiLine(Pose(i));
    }
    WriteText(dir + "/times.txt", times);
    if (with_poses) WriteText(dir + "/poses.txt", poses);
    WriteText(dir + "/calib.txt",
              "P0: 3.0e+01 0 1.55e+01 0 0 3.1e+01 1.15e+01 0 0 0 1 0\n"
              "P1: 3.0e+01 0 1.55e+01 -1 0 3.1e+01 1.15e+01 0 0 0 1 0\n");
  }

  template <typename F>
  void ExpectInputError(F&& f, std::initializer_list<std::string> fragments) {
    try {
      f();
      ADD_FAILURE() << "no InputError";
    } catch (const InputError& e) {
      for (const auto& fragment : fragments) {
        EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
      }
    }
  }

  fs::path root_;
};

void ExpectPoseNear(const slam::Rigid3d& a, const slam::Rigid3d& b) {
  EXPECT_LT((a.translation - b.translation).norm(), 1e-9);
  EXPECT_LT(slam::AngularDistance(a.rotation, b.rotation), 1e-9);
}

TEST_F(DatasetTest, KittiLayoutCameraFramesGroundTruthAndSelection) {
  MakeKitti("seq", 7);
  EXPECT_EQ(DetectDatasetFormat(Path("seq")), "kitti");
  const auto dataset = OpenDataset(Path("seq"));
  EXPECT_EQ(dataset->format(), "kitti");
  EXPECT_EQ(dataset->camera().model, slam::CameraModel::kPerspective);
  EXPECT_EQ(dataset->camera().fx, 30.0);
  EXPECT_EQ(dataset->camera().fy, 31.0);
  EXPECT_EQ(dataset->camera().cx, 15.5);
  EXPECT_EQ(dataset->camera().cy, 11.5);
  EXPECT_EQ(dataset->camera().cols, kCols);  // from the first image
  EXPECT_EQ(dataset->camera().rows, kRows);
  ASSERT_EQ(dataset->size(), 7u);
  EXPECT_TRUE(dataset->has_ground_truth());
  EXPECT_DOUBLE_EQ(dataset->frames()[2].timestamp, 0.203);
  ExpectPoseNear(*dataset->frames()[5].world_from_cam, Pose(5));
  const cv::Mat image = dataset->LoadImage(4);
  EXPECT_EQ(image.type(), CV_8UC1);
  EXPECT_EQ(image.at<unsigned char>(3, 3), 50);
  EXPECT_EQ(dataset->LoadImage(4, /*grayscale=*/false).type(), CV_8UC3);

  DatasetOptions odd;
  odd.frames = *FrameSelection::Parse("1::2");
  const auto odd_frames = OpenDataset(Path("seq"), odd);
  ASSERT_EQ(odd_frames->size(), 3u);
  EXPECT_EQ(odd_frames->frames()[1].index, 3u);
  EXPECT_EQ(odd_frames->LoadImage(1).at<unsigned char>(0, 0), 40);
  const Trajectory gt = odd_frames->GroundTruth();
  ASSERT_EQ(gt.poses.size(), 3u);
  ExpectPoseNear(gt.poses[2].cam_from_world.Inverse(), Pose(5));

  DatasetOptions none;
  none.frames = *FrameSelection::Parse("10:");
  ExpectInputError([&] { OpenDataset(Path("seq"), none); }, {"selects none", "7 frames"});
}

TEST_F(DatasetTest, KittiOfficialTreeAndErrors) {
  MakeKitti("dataset/sequences/05", 3, /*with_poses=*/false);
  std::string poses;
  for (int i = 0; i < 3; ++i) poses += KittiLine(Pose(i));
  WriteText("dataset/poses/05.txt", poses);
  const auto dataset = OpenDataset(Path("dataset/sequences/05"));
  ASSERT_TRUE(dataset->frames()[2].world_from_cam);
  ExpectPoseNear(*dataset->frames()[2].world_from_cam, Pose(2));

  MakeKitti("bad", 3);
  WriteText("bad/times.txt", "0\n0.1\n");
  ExpectInputError([&] { OpenDataset(Path("bad")); }, {"bad/times.txt", "2 timestamps for 3 images"});
  WriteText("bad/times.txt", "0\n0.1\n0.2\n");
  WriteText("bad/poses.txt", KittiLine(Pose(0)));
  ExpectInputError([&] { OpenDataset(Path("bad")); }, {"bad/poses.txt", "1 poses for 3 images"});
  fs::remove(Path("bad/poses.txt"));
  WriteText("bad/calib.txt", "P1: 1 2 3\n");
  ExpectInputError([&] { OpenDataset(Path("bad")); }, {"bad/calib.txt", "P0"});
  WriteText("bad/calib.txt", "P0: 1 0 2 0 0 1 2\n");
  ExpectInputError([&] { OpenDataset(Path("bad")); }, {"bad/calib.txt", "line 1", "12 numbers"});
  // A camera file overrides the calibration, and its size must match the images.
  slam::CameraParams wrong_size = SmallCamera();
  wrong_size.cols = 64;
  WriteCameraFile(wrong_size, Path("wrong.yaml"));
  DatasetOptions options;
  options.camera_file = Path("wrong.yaml");
  ExpectInputError([&] { OpenDataset(Path("bad"), options); }, {"wrong.yaml", "64x24", "32x24"});
  WriteCameraFile(SmallCamera(), Path("right.yaml"));
  options.camera_file = Path("right.yaml");
  EXPECT_EQ(OpenDataset(Path("bad"), options)->camera().name, "small");
  // A missing image is named when loaded.
  const auto dataset_bad = OpenDataset(Path("bad"), options);
  fs::remove(Path("bad/image_0/" + Name6(2)));
  ExpectInputError([&] { dataset_bad->LoadImage(2); }, {Name6(2), "missing"});
}

TEST_F(DatasetTest, TumLayoutAssociatesGroundTruthWithin20ms) {
  std::string rgb = "# color images\n# file: 'rgbd_dataset_freiburg1_xyz.bag'\n# timestamp filename\n";
  for (int i = 0; i < 4; ++i) {
    const std::string name = "rgb/" + std::to_string(100 + i) + ".png";
    WriteImage("tum/" + name, i);
    rgb += FormatDoubleExact(1305031102.0 + 0.1 * i) + " " + name + "\n";
  }
  WriteText("tum/rgb.txt", rgb);
  // Ground truth every 5 ms from frame 1 on, shifted by 2 ms: frame 0 has none.
  std::string gt = "# ground truth trajectory\n";
  for (int k = 0; k < 70; ++k) {
    const double t = 1305031102.1 + 0.002 + 0.005 * k - 0.015;
    gt += TumLine(t, Pose(k));
  }
  WriteText("tum/groundtruth.txt", gt);
  ExpectInputError([&] { OpenDataset(Path("tum")); }, {"no camera", "camera.yaml"});
  WriteCameraFile(SmallCamera(), Path("tum/camera.yaml"));
  EXPECT_EQ(DetectDatasetFormat(Path("tum")), "tum");
  const auto dataset = OpenDataset(Path("tum"));
  ASSERT_EQ(dataset->size(), 4u);
  EXPECT_FALSE(dataset->frames()[0].world_from_cam);  // 87 ms before the first pose
  // Frame 1 at .1: nearest pose k = 3 (t = .1 + .002), frame 3 at .3: k = 43.
  ASSERT_TRUE(dataset->frames()[1].world_from_cam);
  ExpectPoseNear(*dataset->frames()[1].world_from_cam, Pose(3));
  ExpectPoseNear(*dataset->frames()[3].world_from_cam, Pose(43));
  EXPECT_EQ(dataset->LoadImage(2).at<unsigned char>(0, 0), 30);

  // The freiburg intrinsics are known: no camera file needed for rgbd_dataset_freiburg1_*.
  fs::create_directories(Path("rgbd_dataset_freiburg1_xyz"));
  fs::copy(Path("tum/rgb"), Path("rgbd_dataset_freiburg1_xyz/rgb"));
  fs::copy(Path("tum/rgb.txt"), Path("rgbd_dataset_freiburg1_xyz/rgb.txt"));
  // The images here are tiny, so the published 640x480 camera does not fit them.
  ExpectInputError([&] { OpenDataset(Path("rgbd_dataset_freiburg1_xyz")); },
                   {"freiburg1", "640x480", "32x24"});
}

TEST_F(DatasetTest, TumMonoVoLayoutWithDsoCameraFile) {
  std::string times;
  for (int i = 0; i < 3; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "images/%05d.png", i);
    WriteImage(std::string("mono/") + name, i);
    times += std::to_string(i) + " " + FormatDoubleExact(1432893000.0 + 0.05 * i) + " 20.06\n";
  }
  WriteText("mono/times.txt", times);
  // Relative pinhole intrinsics, as DSO writes them: fx * w, cx * w - 0.5.
  WriteText("mono/camera.txt", "Pinhole 0.5 0.75 0.5 0.5 0\n32 24\ncrop\n32 24\n");
  EXPECT_EQ(DetectDatasetFormat(Path("mono")), "tum-mono");
  const auto dataset = OpenDataset(Path("mono"));
  EXPECT_EQ(dataset->format(), "tum-mono");
  EXPECT_DOUBLE_EQ(dataset->camera().fx, 16.0);
  EXPECT_DOUBLE_EQ(dataset->camera().fy, 18.0);
  EXPECT_DOUBLE_EQ(dataset->camera().cx, 15.5);
  EXPECT_DOUBLE_EQ(dataset->camera().cy, 11.5);
  EXPECT_NEAR(dataset->camera().fps, 20.0, 1e-4);  // from ~1.4e9 s timestamps
  ASSERT_EQ(dataset->size(), 3u);
  EXPECT_DOUBLE_EQ(dataset->frames()[2].timestamp, 1432893000.1);
  EXPECT_FALSE(dataset->has_ground_truth());
  EXPECT_EQ(dataset->LoadImage(2).at<unsigned char>(1, 1), 30);

  WriteText("mono/camera.txt", "RadTan 300 300 15.5 11.5 -0.1 0.01 0.001 0.002\n32 24\n");
  EXPECT_DOUBLE_EQ(OpenDataset(Path("mono"))->camera().distortion[3], 0.002);
  // The monoVO sequences' own FOV model cannot be represented: a camera file is needed.
  WriteText("mono/camera.txt", "0.349 0.436 0.493 0.499 0.933\n32 24\ncrop\n640 480\n");
  ExpectInputError([&] { OpenDataset(Path("mono")); }, {"camera.txt", "FOV", "--camera"});
  WriteCameraFile(SmallCamera(), Path("cam.yaml"));
  DatasetOptions options;
  options.camera_file = Path("cam.yaml");
  EXPECT_EQ(OpenDataset(Path("mono"), options)->camera().name, "small");
}

TEST_F(DatasetTest, EurocLayoutConvertsBodyGroundTruthToCamera) {
  const std::string cam0 = "MH_01_easy/mav0/cam0";
  std::string csv = "#timestamp [ns],filename\n";
  for (int i = 0; i < 3; ++i) {
    const std::string stamp = std::to_string(1403636579763555584ULL + 50000000ULL * i);
    WriteImage(cam0 + "/data/" + stamp + ".png", i);
    csv += stamp + "," + stamp + ".png\n";
  }
  WriteText(cam0 + "/data.csv", csv);
  WriteText(cam0 + "/sensor.yaml", R"(%YAML:1.0
sensor_type: camera
comment: VI-Sensor cam0 (MT9M034)
T_BS:
  cols: 4
  rows: 4
  data: [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,
         0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,
        -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,
         0.0, 0.0, 0.0, 1.0]
rate_hz: 20
resolution: [32, 24]
camera_model: pinhole
intrinsics: [30.1, 30.2, 15.3, 11.4] #fu, fv, cu, cv
distortion_model: radial-tangential
distortion_coefficients: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]
)");
  std::string gt = "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], "
                   "q_RS_y [], q_RS_z [], v_RS_R_x [m s^-1], v_RS_R_y, v_RS_R_z, b_w_RS_S_x, "
                   "b_w_RS_S_y, b_w_RS_S_z, b_a_RS_S_x, b_a_RS_S_y, b_a_RS_S_z\n";
  for (int k = 0; k < 30; ++k) {
    const slam::Rigid3d body = Pose(k);
    const auto& q = body.rotation;
    gt += std::to_string(1403636579763555584ULL + 5000000ULL * k) + "," +
          FormatDoubleExact(body.translation.x()) + "," + FormatDoubleExact(body.translation.y()) +
          "," + FormatDoubleExact(body.translation.z()) + "," + FormatDoubleExact(q.w()) + "," +
          FormatDoubleExact(q.x()) + "," + FormatDoubleExact(q.y()) + "," +
          FormatDoubleExact(q.z()) + ",0,0,0,0,0,0,0,0,0\n";
  }
  WriteText("MH_01_easy/mav0/state_groundtruth_estimate0/data.csv", gt);

  EXPECT_EQ(DetectDatasetFormat(Path("MH_01_easy")), "euroc");
  const auto dataset = OpenDataset(Path("MH_01_easy"));
  EXPECT_EQ(dataset->format(), "euroc");
  EXPECT_EQ(dataset->camera().fx, 30.1);
  EXPECT_EQ(dataset->camera().cy, 11.4);
  EXPECT_EQ(dataset->camera().distortion[3], 1.76187114e-05);
  EXPECT_EQ(dataset->camera().fps, 20);
  ASSERT_EQ(dataset->size(), 3u);
  EXPECT_NEAR(dataset->frames()[1].timestamp, 1403636579.813555584, 1e-6);
  Eigen::Matrix<double, 3, 4> t_bs;
  t_bs << 0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975, 0.999557249008,
      0.0149672133247, 0.025715529948, -0.064676986768, -0.0257744366974, 0.00375618835797,
      0.999660727178, 0.00981073058949;
  // Image 2 is 100 ms after the start: ground-truth row 20.
  ASSERT_TRUE(dataset->frames()[2].world_from_cam);
  ExpectPoseNear(*dataset->frames()[2].world_from_cam, Pose(20) * slam::Rigid3d::FromMatrix(t_bs));
  // The mav0 folder itself opens too.
  EXPECT_EQ(OpenDataset(Path("MH_01_easy/mav0"))->size(), 3u);
}

TEST_F(DatasetTest, LcvSceneSequencesAndImageFolder) {
  WriteText("scene/scene.json", "{\"name\": \"test\"}\n");
  for (const std::string seq : {"map", "client"}) {
    std::string times, gt;
    for (int i = 0; i < 3; ++i) {
      WriteImage("scene/" + seq + "/images/" + Name6(i), i);
      times += FormatDoubleExact(0.05 * i) + "\n";
      gt += TumLine(0.05 * i, Pose(i + (seq == "map" ? 0 : 10)));
    }
    WriteText("scene/" + seq + "/times.txt", times);
    WriteText("scene/" + seq + "/groundtruth.txt", gt);
    WriteCameraFile(SmallCamera(), Path("scene/" + seq + "/camera.yaml"));
  }
  EXPECT_EQ(DetectDatasetFormat(Path("scene")), "lcv");
  EXPECT_EQ(DetectDatasetFormat(Path("scene/client")), "lcv");
  ExpectInputError([&] { OpenDataset(Path("scene")); }, {"client, map", "--sequence"});
  DatasetOptions options;
  options.sequence = "client";
  const auto client = OpenDataset(Path("scene"), options);
  EXPECT_EQ(client->format(), "lcv");
  EXPECT_EQ(client->path(), Path("scene/client"));
  ASSERT_EQ(client->size(), 3u);
  ExpectPoseNear(*client->frames()[1].world_from_cam, Pose(11));
  EXPECT_EQ(client->camera().fps, 20.0);
  options.sequence = "nope";
  ExpectInputError([&] { OpenDataset(Path("scene"), options); }, {"no sequence 'nope'"});
  WriteText("scene/map/groundtruth.txt", TumLine(0.0, Pose(0)));
  ExpectInputError([&] { OpenDataset(Path("scene/map")); }, {"groundtruth.txt", "1 poses for 3 images"});

  // A plain folder of images: camera file required; timestamps from its fps.
  for (int i = 0; i < 4; ++i) WriteImage("plain/img_" + std::to_string(i) + ".jpg", i);
  EXPECT_EQ(DetectDatasetFormat(Path("plain")), "images");
  ExpectInputError([&] { OpenDataset(Path("plain")); }, {"plain", "no camera"});
  WriteCameraFile(SmallCamera(), Path("cam.yaml"));
  DatasetOptions with_camera;
  with_camera.camera_file = Path("cam.yaml");
  const auto plain = OpenDataset(Path("plain"), with_camera);
  ASSERT_EQ(plain->size(), 4u);
  EXPECT_DOUBLE_EQ(plain->frames()[3].timestamp, 3.0 / 20.0);
  EXPECT_FALSE(plain->has_ground_truth());
  EXPECT_NEAR(plain->LoadImage(1).at<unsigned char>(5, 5), 20, 2);  // jpeg
  ExpectInputError([&] { OpenDataset(Path("missing")); }, {"missing", "no such file"});
  ExpectInputError([&] { OpenDataset(Path("scene/scene.json")); }, {"unknown dataset layout"});
  DatasetOptions bad_format;
  bad_format.format = "bag";
  ExpectInputError([&] { OpenDataset(Path("plain"), bad_format); }, {"unknown dataset format 'bag'"});
}

TEST_F(DatasetTest, VideoFileWithCameraFile) {
  const std::string video = Path("clip.avi");
  {
    cv::VideoWriter writer(video, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 25.0,
                           cv::Size(kCols, kRows), /*isColor=*/true);
    if (!writer.isOpened()) GTEST_SKIP() << "OpenCV cannot write MJPG AVI here";
    for (int i = 0; i < 6; ++i) {
      writer.write(cv::Mat(kRows, kCols, CV_8UC3, cv::Scalar::all(30 * (i + 1))));
    }
  }
  EXPECT_EQ(DetectDatasetFormat(video), "video");
  ExpectInputError([&] { OpenDataset(video); }, {"clip.avi", "no camera"});
  WriteCameraFile(SmallCamera(), Path("camera.yaml"));  // beside the video
  const auto dataset = OpenDataset(video);
  EXPECT_EQ(dataset->format(), "video");
  ASSERT_EQ(dataset->size(), 6u);
  EXPECT_DOUBLE_EQ(dataset->frames()[5].timestamp, 5.0 / 25.0);  // the container's rate
  EXPECT_TRUE(dataset->frames()[5].image_path.empty());
  EXPECT_NEAR(dataset->LoadImage(4).at<unsigned char>(10, 10), 150, 4);
  EXPECT_NEAR(dataset->LoadImage(1).at<unsigned char>(10, 10), 60, 4);  // backwards: reopens
  const cv::Mat color = dataset->LoadImage(5, /*grayscale=*/false);
  EXPECT_EQ(color.type(), CV_8UC3);
  EXPECT_NEAR(color.at<cv::Vec3b>(3, 3)[1], 180, 4);

  DatasetOptions even;
  even.frames = *FrameSelection::Parse("0::2");
  const auto even_frames = OpenDataset(video, even);
  ASSERT_EQ(even_frames->size(), 3u);
  EXPECT_NEAR(even_frames->LoadImage(2).at<unsigned char>(0, 0), 150, 4);

  WriteText("not_a_video.mp4", "hello");
  ExpectInputError([&] { OpenDataset(Path("not_a_video.mp4")); }, {"not_a_video.mp4", "cannot open video"});
}

TEST(DatasetKitti00Test, ReadsSharedSequenceAsItIs) {
  const std::string dir = std::string(LCV_SHARED_DIR) + "/data/kitti00";
  if (!fs::exists(dir + "/image_0")) GTEST_SKIP() << dir << " not found (shared KITTI data absent)";
  const auto dataset = OpenDataset(dir);
  EXPECT_EQ(dataset->format(), "kitti");
  EXPECT_EQ(dataset->size(), 160u);
  EXPECT_DOUBLE_EQ(dataset->camera().fx, 718.856);
  EXPECT_DOUBLE_EQ(dataset->camera().cx, 607.1928);
  EXPECT_DOUBLE_EQ(dataset->camera().cy, 185.2157);
  EXPECT_EQ(dataset->camera().cols, 1241);
  EXPECT_EQ(dataset->camera().rows, 376);
  EXPECT_TRUE(dataset->has_ground_truth());
  EXPECT_NEAR(dataset->frames()[1].timestamp, 0.1037359, 1e-9);

  DatasetOptions map_half, client_half;
  map_half.frames = *FrameSelection::Parse("1::2");
  client_half.frames = *FrameSelection::Parse("0::2");
  const auto map = OpenDataset(dir, map_half);
  const auto client = OpenDataset(dir, client_half);
  ASSERT_EQ(map->size(), 80u);
  ASSERT_EQ(client->size(), 80u);
  EXPECT_EQ(map->frames()[0].index, 1u);
  EXPECT_EQ(client->frames()[79].index, 158u);
  const cv::Mat image = map->LoadImage(0);
  EXPECT_EQ(image.cols, 1241);
  EXPECT_EQ(image.rows, 376);
  EXPECT_EQ(image.type(), CV_8UC1);
}

}  // namespace
}  // namespace lcv::mapping
