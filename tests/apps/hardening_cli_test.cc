// Issue 16 through the built binary: bad input never crashes or hangs and every error names its
// file; outputs are checked before any work; the camera of a loaded map is never replaced
// silently.
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mapping/io/camera_file.h"
#include "mapping/io/map_file.h"
#include "mapping/line_cloud.h"
#include "mapping/synthetic_map.h"
#include "tests/support/cli_run.h"

namespace lcv {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

class HardeningCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lcv_hardening_cli_test_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    mapping::SyntheticMapOptions options;
    options.num_points = 200;
    options.num_keyframes = 6;
    options.seed = 3;
    points_ = mapping::MakeSyntheticPointMap(options);
    lines_ = mapping::ConvertToLineCloud(points_, mapping::LineCloudOptions{});
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  test::CliResult Run(const std::string& arguments) const {
    return test::RunLcv(arguments, dir_.string());
  }
  // The JSON document of a map, written as is (WriteMap would refuse a corrupted one).
  static json Document(const slam::Map& map) {
    return json::parse(mapping::SerializeMap(map, mapping::MapEncoding::kJson));
  }
  void WriteDocument(const json& document, const std::string& name) const {
    std::ofstream(Path(name)) << document.dump();
  }

  fs::path dir_;
  slam::Map points_, lines_;
};

// Items 1 and 2: huge coordinates crashed render (exit 139) and stopped audit with an internal
// error naming no file; now every command refuses the map, naming it and the value.
TEST_F(HardeningCliTest, HugeCoordinatesAreRefusedByEveryCommandNamingTheFile) {
  json line_cloud = Document(lines_);
  line_cloud["lines"][0]["anchor"][0] = 1e154;
  WriteDocument(line_cloud, "huge_line.json");
  json point_map = Document(points_);
  point_map["keyframes"][1]["cam_from_world"]["translation"][0] = -1e308;
  WriteDocument(point_map, "far_keyframe.json");
  const std::string huge_line = Path("huge_line.json"), far_keyframe = Path("far_keyframe.json");
  const std::vector<std::pair<std::string, std::string>> runs = {
      {"render " + huge_line + " --out " + Path("a.png"), huge_line},
      {"audit " + huge_line + " --report " + Path("r.json"), huge_line},
      {"map info " + huge_line, huge_line},
      {"map info " + far_keyframe, far_keyframe},
      {"audit " + far_keyframe + " --report " + Path("r.json"), far_keyframe},
      {"map convert --to-lines " + far_keyframe + " " + Path("c.lcmap"), far_keyframe},
  };
  for (const auto& [arguments, file] : runs) {
    const test::CliResult result = Run(arguments);
    EXPECT_EQ(result.exit_code, 1) << arguments << "\n" << result.err;
    EXPECT_NE(result.err.find(file + ": /"), std::string::npos) << arguments << "\n" << result.err;
    EXPECT_NE(result.err.find("plausible range"), std::string::npos) << result.err;
    EXPECT_EQ(result.err.find("internal error"), std::string::npos) << result.err;
  }
  EXPECT_FALSE(fs::exists(Path("a.png")));
  EXPECT_FALSE(fs::exists(Path("c.lcmap")));
}

// Item 3: /dev/zero and a 3 GB file of zeros are refused at once, naming the file.
TEST_F(HardeningCliTest, EndlessAndHugeInputsAreRefusedAtOnce) {
  const std::string zeros = Path("zeros.lcmap");
  std::ofstream(zeros).close();
  fs::resize_file(zeros, std::uintmax_t{3} << 30);  // sparse: no disk space used
  for (const std::string& file : {std::string("/dev/zero"), zeros}) {
    for (const std::string& command :
         {"map info " + file, "render " + file + " --out " + Path("z.png"),
          "audit " + file + " --report " + Path("z.json"),
          "map convert --to-lines " + file + " " + Path("z.lcmap")}) {
      const test::CliResult result = Run(command);
      EXPECT_EQ(result.exit_code, 1) << command;
      EXPECT_NE(result.err.find(file + ": not a map file"), std::string::npos)
          << command << "\n" << result.err;
    }
  }
}

// Item 3, memory: the commands that read untrusted maps must start small (README "Hardening":
// ~13 MB instead of ~122 MB). That holds only while lcv does not link OpenCV's imgcodecs or
// videoio (GDAL, GStreamer, FFmpeg, ...) nor OSMesa (LLVM): they are opened at run time
// (mapping/io/media.h, render/offscreen_context.cc). `readelf -d` lists what the binary links.
TEST_F(HardeningCliTest, LcvLinksNoImageVideoOrGlLibrary) {
  const std::string listing = Path("dynamic.txt");
  ASSERT_EQ(std::system(("readelf -d " + std::string(LCV_BINARY) + " > " + listing).c_str()), 0);
  std::ifstream in(listing);
  const std::string dynamic((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_NE(dynamic.find("(NEEDED)"), std::string::npos) << dynamic;
  ASSERT_NE(dynamic.find("libopencv_core"), std::string::npos) << dynamic;
  for (const char* heavy : {"libopencv_imgcodecs", "libopencv_videoio", "libOSMesa", "libgdal", "libLLVM"}) {
    EXPECT_EQ(dynamic.find(heavy), std::string::npos) << heavy << "\n" << dynamic;
  }
}

// The run-time libraries are found from any working directory: from /, synth renders PNGs
// (OSMesa, PNG encoding) and `dataset info` decodes one of them (PNG decoding) to compare its
// size with a camera file of another size.
TEST_F(HardeningCliTest, RenderAndImageDecodingWorkFromAnyWorkingDirectory) {
  const std::string lcv = LCV_BINARY;
  ASSERT_EQ(std::system(("cd / && " + lcv + " synth --scenario tracking --frames 2 --size 64x48 --out " +
                         Path("synth") + " > /dev/null 2>&1").c_str()),
            0);
  ASSERT_TRUE(fs::exists(Path("synth/map/images/000001.png")));
  slam::CameraParams camera = mapping::ReadCameraFile(Path("synth/map/camera.yaml"));
  camera.cols = 32;
  camera.rows = 24;
  mapping::WriteCameraFile(camera, Path("camera32.yaml"));
  const int status = std::system(("cd / && " + lcv + " dataset info " + Path("synth/map/images") + " --camera " +
                                  Path("camera32.yaml") + " > " + Path("info.txt") + " 2>&1").c_str());
  EXPECT_NE(status, 0);
  std::ifstream in(Path("info.txt"));
  const std::string info((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(info.find("differs from the images' 64x48"), std::string::npos) << info;
}

// Item 7: a bad output is found before the work, and nothing else is written.
TEST_F(HardeningCliTest, OutputsAreCheckedBeforeAnyWork) {
  mapping::WriteMap(points_, Path("points.lcmap"));
  fs::create_directories(Path("a_folder"));
  struct Case {
    std::string arguments, output, flag;
  };
  const std::vector<Case> cases = {
      {"map convert --to-lines " + Path("points.lcmap") + " " + Path("a_folder"),
       Path("a_folder"), "(OUT): is a folder"},
      {"map convert --to-lines " + Path("points.lcmap") + " " + Path("missing/l.lcmap"),
       Path("missing/l.lcmap"), "(OUT): cannot be written: its folder"},
      // slam checks every output before opening the dataset (which does not exist here).
      {"slam --dataset " + Path("no_dataset") + " --trajectory-out " + Path("t.txt") +
           " --map-out " + Path("missing/m.lcmap"),
       Path("missing/m.lcmap"), "(--map-out): cannot be written"},
      {"slam --dataset " + Path("no_dataset") + " --trajectory-out " + Path("t.txt") +
           " --stats-out " + Path("a_folder"),
       Path("a_folder"), "(--stats-out): is a folder"},
      {"audit " + Path("points.lcmap") + " --report " + Path("missing/r.json"),
       Path("missing/r.json"), "(--report): cannot be written"},
      {"render " + Path("points.lcmap") + " --out " + Path("a_folder"), Path("a_folder"),
       "(--out): is a folder"},
  };
  for (const Case& c : cases) {
    const test::CliResult result = Run(c.arguments);
    EXPECT_EQ(result.exit_code, 1) << c.arguments << "\n" << result.err;
    EXPECT_NE(result.err.find(c.output + " " + c.flag), std::string::npos)
        << c.arguments << "\n" << result.err;
  }
  EXPECT_FALSE(fs::exists(Path("t.txt"))) << "slam wrote an output before failing";
}

// Items 5 and 8: a loaded map whose camera differs from the dataset's only in its intrinsics is
// used with the dataset's, and stderr says so with both values; a folder given as a camera file
// is named as a folder.
TEST_F(HardeningCliTest, MapCameraReplacementIsAnnouncedAndCameraFolderNamed) {
  const test::CliResult synth = Run("synth --scenario tracking --frames 3 --size 64x32 --out " +
                                    Path("synth"));
  ASSERT_EQ(synth.exit_code, 0) << synth.err;
  const std::string dataset = Path("synth/map");
  slam::CameraParams camera = mapping::ReadCameraFile(dataset + "/camera.yaml");
  const double dataset_fx = camera.fx;
  camera.fx *= 1.25;
  slam::Map map = points_;
  const slam::Id camera_id = map.cameras.begin()->first;
  map.cameras[camera_id] = camera;
  for (auto& [id, kf] : map.keyframes) {
    for (slam::Keypoint& kp : kf.keypoints) {  // keep the keypoints inside the small image
      kp.x = std::fmod(std::abs(kp.x), 63.0f);
      kp.y = std::fmod(std::abs(kp.y), 31.0f);
    }
  }
  mapping::WriteMap(map, Path("other_fx.lcmap"));
  const test::CliResult slam = Run("slam --dataset " + dataset + " --map-in " +
                                   Path("other_fx.lcmap") + " --trajectory-out " + Path("t.txt") +
                                   " --deterministic");
  std::ostringstream fx_change;
  fx_change.precision(17);
  fx_change << "fx " << camera.fx << " -> " << dataset_fx;
  EXPECT_NE(slam.err.find("warning: " + Path("other_fx.lcmap") + ": camera"), std::string::npos)
      << slam.err;
  EXPECT_NE(slam.err.find(fx_change.str()), std::string::npos) << slam.err;

  const test::CliResult folder =
      Run("dataset info " + dataset + " --camera " + Path("synth"));
  EXPECT_EQ(folder.exit_code, 1);
  EXPECT_NE(folder.err.find(Path("synth") + ": is a folder, not a file"), std::string::npos)
      << folder.err;
  // Item 3: a camera file that never ends.
  const test::CliResult zero = Run("dataset info " + dataset + " --camera /dev/zero");
  EXPECT_EQ(zero.exit_code, 1);
  EXPECT_NE(zero.err.find("/dev/zero: binary data"), std::string::npos) << zero.err;
}

}  // namespace
}  // namespace lcv
