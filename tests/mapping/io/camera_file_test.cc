#include "mapping/io/camera_file.h"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mapping/io/yaml_subset.h"
#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

namespace fs = std::filesystem;

// Expects ParseCameraFile to throw an InputError whose message contains every fragment.
void ExpectCameraError(const std::string& text, std::initializer_list<std::string> fragments) {
  try {
    ParseCameraFile(text, "cam.yaml");
    ADD_FAILURE() << "no error for:\n" << text;
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.rfind("cam.yaml: ", 0), 0u) << message;
    for (const auto& f : fragments) EXPECT_NE(message.find(f), std::string::npos) << message;
  }
}

TEST(CameraFileTest, ReadsStellaVslamSection) {
  const std::string text = R"(# KITTI settings
Camera:
  name: "KITTI Monocular 00-02"
  setup: "monocular"
  model: "perspective"
  fx: 718.856
  fy: 718.856
  cx: 607.1928
  cy: 185.2157
  k1: 0.0
  k2: -0.25   # trailing comment
  p1: 0.001
  p2: 0.0
  k3: 0.0
  fps: 10.0
  cols: 1241
  rows: 376
  color_order: "Gray"

Feature:
  max_num_keypoints: 2000
)";
  const slam::CameraParams p = ParseCameraFile(text, "kitti.yaml");
  EXPECT_EQ(p.name, "KITTI Monocular 00-02");
  EXPECT_EQ(p.model, slam::CameraModel::kPerspective);
  EXPECT_DOUBLE_EQ(p.fx, 718.856);
  EXPECT_DOUBLE_EQ(p.fy, 718.856);
  EXPECT_DOUBLE_EQ(p.cx, 607.1928);
  EXPECT_DOUBLE_EQ(p.cy, 185.2157);
  EXPECT_DOUBLE_EQ(p.distortion[1], -0.25);
  EXPECT_DOUBLE_EQ(p.distortion[2], 0.001);
  EXPECT_EQ(p.cols, 1241);
  EXPECT_EQ(p.rows, 376);
  EXPECT_DOUBLE_EQ(p.fps, 10.0);
}

TEST(CameraFileTest, ReadsFlatKeysWithOpenCvHeaderAndTopLevelFields) {
  const std::string flat = "%YAML:1.0\n---\nCamera.model: fisheye\nCamera.fx: 300\nCamera.fy: 301\n"
                           "Camera.cx: 320\nCamera.cy: 240\nCamera.k1: 0.1\nCamera.k4: -0.01\n"
                           "Camera.cols: 640\nCamera.rows: 480\n";
  const slam::CameraParams f = ParseCameraFile(flat, "flat.yaml");
  EXPECT_EQ(f.model, slam::CameraModel::kFisheye);
  EXPECT_DOUBLE_EQ(f.fy, 301);
  EXPECT_DOUBLE_EQ(f.distortion[0], 0.1);
  EXPECT_DOUBLE_EQ(f.distortion[3], -0.01);
  EXPECT_DOUBLE_EQ(f.fps, 30.0);  // default

  const std::string top = "model: equirectangular\nwidth: 2048\nheight: 1024\nfps: 15\n";
  const slam::CameraParams e = ParseCameraFile(top, "top.yaml");
  EXPECT_EQ(e.model, slam::CameraModel::kEquirectangular);
  EXPECT_EQ(e.cols, 2048);
  EXPECT_EQ(e.rows, 1024);
}

TEST(CameraFileTest, ReadsJson) {
  const std::string text = R"({"Camera": {"model": "perspective", "fx": 500, "fy": 500,
      "cx": 319.5, "cy": 239.5, "k1": -0.1, "cols": 640, "rows": 480, "fps": 20}})";
  const slam::CameraParams p = ParseCameraFile(text, "cam.json");
  EXPECT_DOUBLE_EQ(p.cx, 319.5);
  EXPECT_DOUBLE_EQ(p.distortion[0], -0.1);
  EXPECT_DOUBLE_EQ(p.fps, 20);
}

TEST(CameraFileTest, WriteReadRoundTripIsExact) {
  slam::CameraParams p;
  p.name = "synthetic \"cam\" #1\t\x01 \xc3\xa9";  // quotes, comment char, control, UTF-8
  p.model = slam::CameraModel::kPerspective;
  p.fx = 0.1 + 0.2 + 700;  // not exactly representable in short decimal
  p.fy = 701.123456789012345;
  p.cx = 320.5;
  p.cy = 1.0 / 3.0 * 700;
  p.distortion = {-0.2, 0.05, 1e-4, -3e-5, 1e-9};
  p.cols = 640;
  p.rows = 480;
  p.fps = 29.97;
  const fs::path path = fs::temp_directory_path() /
                        ("lcv_camera_file_test_" + std::to_string(::getpid()) + ".yaml");
  WriteCameraFile(p, path.string());
  const slam::CameraParams q = ReadCameraFile(path.string());
  fs::remove(path);
  EXPECT_EQ(q.name, p.name);
  EXPECT_EQ(q.model, p.model);
  EXPECT_EQ(q.fx, p.fx);
  EXPECT_EQ(q.fy, p.fy);
  EXPECT_EQ(q.cx, p.cx);
  EXPECT_EQ(q.cy, p.cy);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(q.distortion[i], p.distortion[i]) << i;
  EXPECT_EQ(q.cols, p.cols);
  EXPECT_EQ(q.rows, p.rows);
  EXPECT_EQ(q.fps, p.fps);

  slam::CameraParams fisheye = p;
  fisheye.model = slam::CameraModel::kFisheye;
  fisheye.distortion = {0.1, -0.02, 0.003, -4e-4, 0.0};
  const slam::CameraParams g = ParseCameraFile(SerializeCameraFile(fisheye), "fisheye.yaml");
  EXPECT_EQ(g.model, slam::CameraModel::kFisheye);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(g.distortion[i], fisheye.distortion[i]) << i;
}

TEST(CameraFileTest, BadInputNamesFileFieldAndValue) {
  const std::string good_tail = "  fy: 500\n  cx: 320\n  cy: 240\n  cols: 640\n  rows: 480\n";
  ExpectCameraError("Camera:\n  model: perspective\n  fx: abc\n" + good_tail,
                    {"Camera.fx", "expected a number", "abc"});
  ExpectCameraError("Camera:\n  model: pinhole-ish\n  fx: 500\n" + good_tail,
                    {"Camera.model", "pinhole-ish"});
  ExpectCameraError("Camera:\n  fx: 500\n" + good_tail, {"Camera.model", "missing"});
  ExpectCameraError("Camera:\n  model: perspective\n" + good_tail, {"Camera.fx", "missing"});
  ExpectCameraError("Camera:\n  model: perspective\n  fx: 500\n  fy: 500\n  cx: 320\n  cy: 240\n"
                    "  rows: 480\n",
                    {"Camera.cols", "missing"});
  ExpectCameraError("Camera:\n  model: perspective\n  fx: 500\n  fy: 500\n  cx: 320\n  cy: 240\n"
                    "  cols: 640.5\n  rows: 480\n",
                    {"Camera.cols", "integer", "640.5"});
  ExpectCameraError("Camera:\n  model: perspective\n  fx: -500\n" + good_tail, {"Camera:", "fx"});
  ExpectCameraError("Camera:\n  model: perspective\n  fx: 500\n  fps: 0\n" + good_tail,
                    {"Camera.fps", "> 0"});
  ExpectCameraError("Camera:\n  model: perspective\n  fx: 500\n  fx: 501\n" + good_tail,
                    {"line 4", "duplicate key 'fx'"});
  ExpectCameraError("Camera:\n  model: perspective\n   fx: 500\n" + good_tail,
                    {"line 3", "indentation"});
  ExpectCameraError("Camera:\n\tmodel: perspective\n", {"line 2", "tab"});
  ExpectCameraError("Camera: [1, 2\n", {"line 1", "unclosed"});
  ExpectCameraError("Camera:\n  name: \"open\n", {"line 2", "quote"});
  ExpectCameraError("{\"Camera\": {\"model\": }", {"invalid JSON"});
  ExpectCameraError("", {"empty"});
  ExpectCameraError("- 1\n- 2\n", {"mapping"});
  ExpectCameraError("Camera: 5\n", {"Camera", "mapping"});
}

TEST(CameraFileTest, MissingFileIsNamed) {
  try {
    ReadCameraFile("/nonexistent/dir/cam.yaml");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/dir/cam.yaml"), std::string::npos);
  }
}

TEST(CameraFileTest, OptionalImageSizeForDatasetReaders) {
  CameraFileOptions options;
  options.require_image_size = false;
  const slam::CameraParams p = ParseCameraFile(
      "model: perspective\nfx: 500\nfy: 500\ncx: 320\ncy: 240\n", "cam.yaml", options);
  EXPECT_EQ(p.cols, 0);
  EXPECT_EQ(p.rows, 0);
  EXPECT_THROW(CheckCameraParams(p, "cam.yaml"), InputError);
}

TEST(CameraFileTest, FormatDoubleExactIsShortAndExact) {
  EXPECT_EQ(FormatDoubleExact(718.856), "718.856");
  EXPECT_EQ(FormatDoubleExact(0.0), "0");
  const double hard = 0.1 + 0.2;
  EXPECT_EQ(std::stod(FormatDoubleExact(hard)), hard);
}

// The YAML subset itself: EuRoC's sensor.yaml shape (multi-line flow sequences, tags, nested
// mappings, block sequences).
TEST(YamlSubsetTest, ParsesEurocSensorYaml) {
  const std::string text = R"(%YAML:1.0
# General sensor definitions.
sensor_type: camera
comment: VI-Sensor cam0 (MT9M034)

# Sensor extrinsics wrt. the body-frame.
T_BS: !!opencv-matrix
  cols: 4
  rows: 4
  data: [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,
         0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,
        -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,
         0.0, 0.0, 0.0, 1.0]

# Camera specific definitions.
rate_hz: 20
resolution: [752, 480]
camera_model: pinhole
intrinsics: [458.654, 457.296, 367.215, 248.375] #fu, fv, cu, cv
distortion_model: radial-tangential
distortion_coefficients: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]
list:
- a: 1
  b: 'it''s'
- - x
  - y
- {k: v, n: -2}
empty:
)";
  const nlohmann::json j = ParseYamlSubset(text, "sensor.yaml");
  EXPECT_EQ(j["sensor_type"], "camera");
  EXPECT_EQ(j["comment"], "VI-Sensor cam0 (MT9M034)");
  EXPECT_EQ(j["T_BS"]["cols"], 4);
  ASSERT_EQ(j["T_BS"]["data"].size(), 16u);
  EXPECT_DOUBLE_EQ(j["T_BS"]["data"][1].get<double>(), -0.999880929698);
  EXPECT_DOUBLE_EQ(j["T_BS"]["data"][8].get<double>(), -0.0257744366974);
  EXPECT_EQ(j["rate_hz"], 20);
  EXPECT_EQ(j["resolution"][0], 752);
  EXPECT_DOUBLE_EQ(j["intrinsics"][3].get<double>(), 248.375);
  EXPECT_DOUBLE_EQ(j["distortion_coefficients"][3].get<double>(), 1.76187114e-05);
  EXPECT_EQ(j["distortion_model"], "radial-tangential");
  ASSERT_EQ(j["list"].size(), 3u);
  EXPECT_EQ(j["list"][0]["a"], 1);
  EXPECT_EQ(j["list"][0]["b"], "it's");
  EXPECT_EQ(j["list"][1][1], "y");
  EXPECT_EQ(j["list"][2]["n"], -2);
  EXPECT_TRUE(j["empty"].is_null());
}

// Mutated camera files (YAML and JSON) are either read or rejected with an InputError: no
// crash, no other exception.
TEST(CameraFileTest, MutatedFilesNeverCrash) {
  const std::uint64_t seed = 77;
  std::mt19937_64 rng(seed);
  const std::string yaml =
      "%YAML:1.0\n# comment\nCamera:\n  name: \"a \\\"b\\\"\"\n  model: 'perspective'\n"
      "  fx: 500.5\n  fy: 500\n  cx: 320\n  cy: 240\n  k1: [1, {a: 2}]\n  cols: 640\n"
      "  rows: 480\n  list:\n  - x: 1\n    y: [2, 3]\n  - - 4\n";
  const std::string json_text =
      R"({"Camera": {"model": "fisheye", "fx": 300, "fy": 300, "cx": 320, "cy": 240, "k1": 0.1, "cols": 640, "rows": 480}})";
  const std::string alphabet = " \t\n:-#[]{},\"'!&*|>%.0123456789eE+-abc\\";
  int accepted = 0, rejected = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    std::string text = trial % 2 ? yaml : json_text;
    const int edits = 1 + static_cast<int>(rng() % 4);
    for (int e = 0; e < edits && !text.empty(); ++e) {
      const size_t pos = rng() % text.size();
      switch (rng() % 3) {
        case 0: text[pos] = alphabet[rng() % alphabet.size()]; break;
        case 1: text.erase(pos, 1 + rng() % 3); break;
        default: text.insert(pos, 1, alphabet[rng() % alphabet.size()]); break;
      }
    }
    try {
      ParseCameraFile(text, "fuzz.yaml");
      ++accepted;
    } catch (const InputError&) {
      ++rejected;
    } catch (const std::exception& e) {
      FAIL() << "seed " << seed << " trial " << trial << ": " << e.what() << "\n" << text;
    }
  }
  EXPECT_GT(accepted, 0);
  EXPECT_GT(rejected, 0);
}

TEST(YamlSubsetTest, RejectsUnsupportedFeatures) {
  EXPECT_THROW(ParseYamlSubset("a: &x 1\nb: *x\n", "f.yaml"), InputError);
  EXPECT_THROW(ParseYamlSubset("a: |\n  text\n", "f.yaml"), InputError);
  EXPECT_THROW(ParseYamlSubset("a: 1\n---\nb: 2\n", "f.yaml"), InputError);
  EXPECT_THROW(ParseYamlSubset("a: [1, 2]]\n", "f.yaml"), InputError);
  EXPECT_THROW(ParseYamlSubset("a: \"x\" y\n", "f.yaml"), InputError);
  EXPECT_THROW(ParseYamlSubset("just text\n", "f.yaml"), InputError);
  EXPECT_TRUE(ParseYamlSubset("# only a comment\n", "f.yaml").is_null());
}

}  // namespace
}  // namespace lcv::mapping
