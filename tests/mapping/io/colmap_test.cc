#include "mapping/io/colmap.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "mapping/io/map_file.h"
#include "mapping/line_cloud.h"
#include "mapping/synthetic_map.h"
#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

namespace fs = std::filesystem;

class TempDir {
 public:
  TempDir() {
    static int counter = 0;
    path_ = fs::temp_directory_path() /
            ("lcv_colmap_test_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string str() const { return path_.string(); }
  void Write(const std::string& name, const std::string& text) const {
    std::ofstream(path_ / name) << text;
  }

 private:
  fs::path path_;
};

// Writes a synthetic map as a COLMAP text model, with COLMAP's conventions: pixel origin at the
// corner of the top-left pixel, ids per table (image = keyframe id - 1, point = index + 1).
void WriteColmapModel(const slam::Map& map, const TempDir& dir, double error_px) {
  std::ostringstream cameras, images, points;
  cameras << std::setprecision(17) << "# Camera list\n";
  images << std::setprecision(17) << "# Image list with two lines of data per image:\n";
  points << std::setprecision(17) << "# 3D point list\n";
  for (const auto& [id, c] : map.cameras) {
    cameras << id << " PINHOLE " << c.cols << " " << c.rows << " " << c.fx << " " << c.fy << " "
            << c.cx + 0.5 << " " << c.cy + 0.5 << "\n";
  }
  std::map<slam::Id, std::map<std::uint32_t, std::int64_t>> point_of_keypoint;
  std::map<slam::Id, std::int64_t> colmap_point_id;
  std::int64_t next = 1;
  for (const auto& [id, p] : map.points) {
    colmap_point_id[id] = next++;
    for (const auto& obs : p.observations) {
      point_of_keypoint[obs.keyframe_id][obs.keypoint_index] = colmap_point_id[id];
    }
  }
  int frame = 0;
  for (const auto& [id, kf] : map.keyframes) {
    const auto& q = kf.cam_from_world.rotation;
    const auto& t = kf.cam_from_world.translation;
    char name[32];
    std::snprintf(name, sizeof(name), "%06d.png", frame++);
    images << id - 1 << " " << q.w() << " " << q.x() << " " << q.y() << " " << q.z() << " " << t.x()
           << " " << t.y() << " " << t.z() << " " << kf.camera_id << " " << name << "\n";
    for (std::uint32_t i = 0; i < kf.keypoints.size(); ++i) {
      const auto it = point_of_keypoint[id].find(i);
      images << (i ? " " : "") << double(kf.keypoints[i].x) + 0.5 << " "
             << double(kf.keypoints[i].y) + 0.5 << " "
             << (it == point_of_keypoint[id].end() ? -1 : it->second);
    }
    images << "\n";
  }
  for (const auto& [id, p] : map.points) {
    points << colmap_point_id[id] << " " << p.position.x() << " " << p.position.y() << " "
           << p.position.z() << " 128 64 32 " << error_px;
    for (const auto& obs : p.observations)
      points << " " << obs.keyframe_id - 1 << " " << obs.keypoint_index;
    points << "\n";
  }
  dir.Write("cameras.txt", cameras.str());
  dir.Write("images.txt", images.str());
  dir.Write("points3D.txt", points.str());
}

slam::Map Synthetic() {
  SyntheticMapOptions o;
  o.num_points = 150;
  o.num_keyframes = 6;
  o.seed = 8;
  return MakeSyntheticPointMap(o);
}

void ExpectImportFails(const TempDir& dir, const std::vector<std::string>& fragments) {
  try {
    ReadColmapTextModel(dir.str());
    ADD_FAILURE() << "accepted; expected " << fragments.front();
  } catch (const InputError& e) {
    for (const auto& f : fragments) {
      EXPECT_NE(std::string(e.what()).find(f), std::string::npos) << e.what();
    }
  }
}

TEST(ColmapImport, ReadsASyntheticModelExactly) {
  const slam::Map truth = Synthetic();
  TempDir dir;
  WriteColmapModel(truth, dir, 1.0);
  const slam::Map map = ReadColmapTextModel(dir.str());
  EXPECT_NO_THROW(ValidateMap(map, "imported"));
  ASSERT_EQ(map.cameras.size(), 1u);
  const slam::CameraParams& c = map.cameras.at(1);
  const slam::CameraParams& tc = truth.cameras.at(1);
  EXPECT_EQ(c.model, slam::CameraModel::kPerspective);
  EXPECT_EQ(c.cols, tc.cols);
  EXPECT_EQ(c.fx, tc.fx);
  EXPECT_DOUBLE_EQ(c.cx, tc.cx);
  EXPECT_DOUBLE_EQ(c.cy, tc.cy);
  // Offsets: image id + 1 (max camera id), point id + 1 + 6: the synthetic ids come back.
  ASSERT_EQ(map.keyframes.size(), truth.keyframes.size());
  double expected_timestamp = 0.0;
  for (const auto& [id, kf] : truth.keyframes) {
    ASSERT_TRUE(map.keyframes.count(id)) << id;
    const slam::Keyframe& got = map.keyframes.at(id);
    EXPECT_EQ(got.camera_id, 1u);
    EXPECT_EQ(got.timestamp, expected_timestamp++);
    EXPECT_LT(slam::AngularDistance(got.cam_from_world.rotation, kf.cam_from_world.rotation),
              1e-12);
    EXPECT_LT((got.cam_from_world.translation - kf.cam_from_world.translation).norm(), 1e-12);
    ASSERT_EQ(got.keypoints.size(), kf.keypoints.size());
    for (size_t i = 0; i < kf.keypoints.size(); ++i) {
      EXPECT_EQ(got.keypoints[i].x, kf.keypoints[i].x);
      EXPECT_EQ(got.keypoints[i].y, kf.keypoints[i].y);
    }
    EXPECT_TRUE(got.descriptors.empty());
  }
  ASSERT_EQ(map.points.size(), truth.points.size());
  // The prior of the covariance, as documented: 10 x median camera-to-point distance.
  std::vector<double> distances;
  for (const auto& [id, p] : truth.points) {
    for (const auto& obs : p.observations) {
      distances.push_back((truth.keyframes.at(obs.keyframe_id).cam_from_world * p.position).norm());
    }
  }
  std::nth_element(distances.begin(), distances.begin() + distances.size() / 2, distances.end());
  const double prior_sigma = 10.0 * distances[distances.size() / 2];
  for (const auto& [id, p] : truth.points) {
    ASSERT_TRUE(map.points.count(id)) << id;
    const slam::PointLandmark& got = map.points.at(id);
    EXPECT_EQ(got.position, p.position);
    EXPECT_FALSE(got.descriptor.has_value());
    ASSERT_EQ(got.observations.size(), p.observations.size());
    Eigen::Matrix3d info = Eigen::Matrix3d::Identity() / (prior_sigma * prior_sigma);
    for (size_t i = 0; i < p.observations.size(); ++i) {
      EXPECT_EQ(got.observations[i].keyframe_id, p.observations[i].keyframe_id);
      EXPECT_EQ(got.observations[i].keypoint_index, p.observations[i].keypoint_index);
      // Pinhole Jacobian by central differences, sigma = ERROR = 1 px.
      const slam::Rigid3d& T = truth.keyframes.at(p.observations[i].keyframe_id).cam_from_world;
      auto project = [&](const Eigen::Vector3d& x) {
        const Eigen::Vector3d q = T * x;
        return Eigen::Vector2d(tc.fx * q.x() / q.z(), tc.fy * q.y() / q.z());
      };
      Eigen::Matrix<double, 2, 3> J;
      for (int a = 0; a < 3; ++a) {
        Eigen::Vector3d h = Eigen::Vector3d::Zero();
        h(a) = 1e-6;
        J.col(a) = (project(p.position + h) - project(p.position - h)) / 2e-6;
      }
      info += J.transpose() * J;
    }
    EXPECT_LT((info * got.covariance - Eigen::Matrix3d::Identity()).norm(), 1e-4) << id;
  }
  // Ready for publishing.
  const slam::Map lines = ConvertToLineCloud(map, LineCloudOptions{1});
  EXPECT_TRUE(slam::IsPublishedLineCloud(lines));
  EXPECT_EQ(lines.lines.size(), truth.points.size());
}

TEST(ColmapImport, LargerErrorGivesLargerCovariance) {
  const slam::Map truth = Synthetic();
  TempDir sharp, blurred;
  WriteColmapModel(truth, sharp, 0.1);  // floored at min_sigma_px = 0.5
  WriteColmapModel(truth, blurred, 2.0);
  const slam::Map a = ReadColmapTextModel(sharp.str());
  const slam::Map b = ReadColmapTextModel(blurred.str());
  for (const auto& [id, p] : a.points) {
    // sigma 0.5 vs 2: the covariance scales by 16 up to the (weak) prior.
    EXPECT_NEAR(b.points.at(id).covariance.trace() / p.covariance.trace(), 16.0, 0.5);
  }
}

TEST(ColmapImport, CameraModels) {
  TempDir dir;
  dir.Write("cameras.txt",
            "# comment\n"
            "1 SIMPLE_PINHOLE 100 80 50 50.5 40.5\n"
            "2 PINHOLE 100 80 50 60 50.5 40.5\n"
            "3 SIMPLE_RADIAL 100 80 50 50.5 40.5 0.01\n"
            "4 RADIAL 100 80 50 50.5 40.5 0.01 -0.002\n"
            "5 OPENCV 100 80 50 60 50.5 40.5 0.01 -0.002 0.001 0.0005\n"
            "6 FULL_OPENCV 100 80 50 60 50.5 40.5 0.01 -0.002 0.001 0.0005 0.0001 0 0 0\n"
            "7 OPENCV_FISHEYE 100 80 50 60 50.5 40.5 0.01 -0.002 0.001 0.0005\n");
  dir.Write("images.txt", "");
  dir.Write("points3D.txt", "");
  const slam::Map map = ReadColmapTextModel(dir.str());
  ASSERT_EQ(map.cameras.size(), 7u);
  for (const auto& [id, c] : map.cameras) {
    EXPECT_EQ(c.cols, 100);
    EXPECT_EQ(c.rows, 80);
    EXPECT_EQ(c.fx, 50.0);
    EXPECT_EQ(c.fy, (id == 1 || id == 3 || id == 4) ? 50.0 : 60.0);
    EXPECT_EQ(c.cx, 50.0);  // COLMAP's 50.5 shifted to the pixel-centre convention
    EXPECT_EQ(c.cy, 40.0);
    EXPECT_EQ(c.model, id == 7 ? slam::CameraModel::kFisheye : slam::CameraModel::kPerspective);
  }
  using D = std::array<double, 5>;
  EXPECT_EQ(map.cameras.at(1).distortion, (D{0, 0, 0, 0, 0}));
  EXPECT_EQ(map.cameras.at(3).distortion, (D{0.01, 0, 0, 0, 0}));
  EXPECT_EQ(map.cameras.at(4).distortion, (D{0.01, -0.002, 0, 0, 0}));
  EXPECT_EQ(map.cameras.at(5).distortion, (D{0.01, -0.002, 0.001, 0.0005, 0}));
  EXPECT_EQ(map.cameras.at(6).distortion, (D{0.01, -0.002, 0.001, 0.0005, 0.0001}));
  EXPECT_EQ(map.cameras.at(7).distortion, (D{0.01, -0.002, 0.001, 0.0005, 0}));
}

TEST(ColmapImport, RejectsBadInputNamingFileAndLine) {
  {
    TempDir dir;
    ExpectImportFails(dir, {dir.str() + "/cameras.txt", "cannot open"});
  }
  EXPECT_THROW(ReadColmapTextModel("/nonexistent/colmap/model"), InputError);
  const slam::Map truth = Synthetic();
  struct Case {
    const char* file;
    std::function<std::string(std::string)> corrupt;
    std::vector<std::string> fragments;
  };
  auto replace_line = [](int line, const std::string& with) {
    return [line, with](std::string text) {
      std::istringstream in(text);
      std::ostringstream out;
      std::string l;
      for (int n = 1; std::getline(in, l); ++n) out << (n == line ? with : l) << "\n";
      return out.str();
    };
  };
  const std::vector<Case> cases = {
      {"cameras.txt",
       replace_line(2, "1 FOV 640 360 450 320 180 0.1"),
       {"cameras.txt:2:", "camera model FOV is not supported"}},
      {"cameras.txt",
       replace_line(2, "1 PINHOLE 640 360 450 450 320"),
       {"cameras.txt:2:", "has 4 parameters, got 3"}},
      {"cameras.txt",
       replace_line(2, "1 PINHOLE 640 360 -450 450 320 180"),
       {"cameras.txt:2:", "fx"}},
      {"cameras.txt",
       replace_line(2, "1 PINHOLE 640 360 abc 450 320 180"),
       {"cameras.txt:2:", "'abc' is not a finite number"}},
      {"cameras.txt",
       replace_line(2, "1 FULL_OPENCV 640 360 450 450 320 180 0 0 0 0 0 0.1 0 0"),
       {"cameras.txt:2:", "rational"}},
      {"cameras.txt", replace_line(2, ""), {"cameras.txt", "no cameras"}},
      {"images.txt", replace_line(2, "1 1 0 0 0 0 0 0 1"), {"images.txt:2:", "got 9 fields"}},
      {"images.txt", replace_line(2, "1 2 0 0 0 0 0 0 1 a.png"), {"images.txt:2:", "norm 2"}},
      {"images.txt", replace_line(3, "1.5 2.5"), {"images.txt:3:", "triples"}},
      {"images.txt", replace_line(3, "1.5 2.5 nan"), {"images.txt:3:", "POINT3D_ID"}},
      {"images.txt",
       replace_line(2, "1 1 0 0 0 0 0 0 9 a.png"),
       {"images.txt:2:", "CAMERA_ID 9 is not in cameras.txt"}},
      {"points3D.txt", replace_line(2, "1 0 0 1 0 0 0 1.0 1"), {"points3D.txt:2:", "got 9 fields"}},
      {"points3D.txt", replace_line(2, "1 0 0 inf 0 0 0 1.0"), {"points3D.txt:2:", "'inf'"}},
      {"points3D.txt",
       replace_line(2, "1 0 0 1 0 0 0 1.0 77 0"),
       {"points3D.txt:2:", "IMAGE_ID 77", "no such image"}},
      {"points3D.txt",
       replace_line(2, "1 0 0 1 0 0 0 1.0 1 100000"),
       {"points3D.txt:2:", "POINT2D_IDX 100000"}},
      {"points3D.txt",
       replace_line(3, "1 0 0 1 0 0 0 1.0"),
       {"points3D.txt:3:", "duplicate POINT3D_ID 1"}},
      {"points3D.txt", replace_line(2, "1 0 0 1 300 0 0 1.0"), {"points3D.txt:2:", "colour 300"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.fragments.back());
    TempDir dir;
    WriteColmapModel(truth, dir, 1.0);
    const std::string path = dir.str() + "/" + c.file;
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    dir.Write(c.file, c.corrupt(text.str()));
    ExpectImportFails(dir, c.fragments);
  }
}

TEST(ColmapImport, TrackMustAgreeWithImages) {
  const slam::Map truth = Synthetic();
  TempDir dir;
  WriteColmapModel(truth, dir, 1.0);
  // Point 1's first track element points at keypoint of another point.
  std::ifstream in(dir.str() + "/points3D.txt");
  std::stringstream text;
  text << in.rdbuf();
  std::string s = text.str();
  const std::size_t line_start = s.find("\n1 ") + 1;
  const std::size_t line_end = s.find('\n', line_start);
  std::istringstream fields(s.substr(line_start, line_end - line_start));
  std::vector<std::string> t;
  for (std::string f; fields >> f;) t.push_back(f);
  const slam::Keyframe& kf = truth.keyframes.at(std::stoull(t[8]) + 1);
  const std::uint32_t wrong = (std::stoul(t[9]) + 1) % kf.keypoints.size();
  t[9] = std::to_string(wrong);
  std::string line;
  for (const auto& f : t) line += (line.empty() ? "" : " ") + f;
  s.replace(line_start, line_end - line_start, line);
  dir.Write("points3D.txt", s);
  ExpectImportFails(dir, {"points3D.txt:2:", "disagrees with images.txt line"});
}

}  // namespace
}  // namespace lcv::mapping
