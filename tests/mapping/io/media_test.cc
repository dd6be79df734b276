// Images and videos through the lcv_media plugin (mapping/io/media.h), and the run-time library
// loading under it (mapping/io/shared_library.h): round trips, undecodable files, and a missing
// library or symbol reported with the file's name.
#include "mapping/io/media.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "mapping/io/atomic_file.h"
#include "mapping/io/shared_library.h"
#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

namespace fs = std::filesystem;

fs::path TempDir() {
  const fs::path dir = fs::temp_directory_path() / ("lcv_media_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir;
}

cv::Mat Gradient(int cols, int rows) {
  cv::Mat image(rows, cols, CV_8UC3);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) image.at<cv::Vec3b>(r, c) = cv::Vec3b(c * 7 % 256, r * 11 % 256, (r + c) % 256);
  }
  return image;
}

TEST(MediaTest, PngRoundTripIsLosslessInEveryMode) {
  const cv::Mat image = Gradient(37, 21);
  const std::string path = (TempDir() / "gradient.png").string();
  const std::vector<unsigned char> png = EncodePng(image, 6, path);
  ASSERT_GT(png.size(), 8u);
  EXPECT_EQ(std::string(png.begin(), png.begin() + 4), "\x89PNG");
  WriteFileAtomically(path, std::string(png.begin(), png.end()));

  const cv::Mat color = ReadImageFile(path, ImageMode::kColor);
  ASSERT_EQ(color.type(), CV_8UC3);
  EXPECT_EQ(cv::norm(color, image, cv::NORM_INF), 0.0);
  const cv::Mat unchanged = ReadImageFile(path, ImageMode::kUnchanged);
  EXPECT_EQ(cv::norm(unchanged, image, cv::NORM_INF), 0.0);
  const cv::Mat gray = ReadImageFile(path, ImageMode::kGray);
  ASSERT_EQ(gray.type(), CV_8UC1);
  EXPECT_EQ(gray.cols, 37);
  EXPECT_EQ(gray.rows, 21);
}

TEST(MediaTest, UndecodableOrMissingImageIsEmpty) {
  const std::string text = (TempDir() / "text.png").string();
  std::ofstream(text) << "not an image";
  EXPECT_TRUE(ReadImageFile(text, ImageMode::kColor).empty());
  EXPECT_TRUE(ReadImageFile((TempDir() / "missing.png").string(), ImageMode::kGray).empty());
}

TEST(MediaTest, VideoRoundTripKeepsFrameCountAndSize) {
  const std::string path = (TempDir() / "clip.avi").string();
  {
    const std::unique_ptr<VideoWriter> writer = CreateVideoFile(path, "MJPG", 10.0, cv::Size(32, 24));
    ASSERT_TRUE(writer);
    for (int i = 0; i < 5; ++i) writer->Write(Gradient(32, 24));
  }
  const std::unique_ptr<VideoReader> reader = OpenVideoFile(path);
  ASSERT_TRUE(reader);
  EXPECT_EQ(reader->Width(), 32);
  EXPECT_EQ(reader->Height(), 24);
  EXPECT_EQ(reader->FrameCount(), 5.0);
  EXPECT_NEAR(reader->Fps(), 10.0, 1e-6);
  cv::Mat frame;
  int frames = 0;
  while (reader->Read(&frame)) ++frames;
  EXPECT_EQ(frames, 5);
  EXPECT_EQ(CreateVideoFile(path, "toolong", 10.0, cv::Size(32, 24)), nullptr);
  EXPECT_EQ(OpenVideoFile((TempDir() / "missing.avi").string()), nullptr);
}

TEST(SharedLibraryTest, MissingLibraryIsNamedWithEveryCandidateAndThePurpose) {
  try {
    SharedLibrary::Open({"/nonexistent/dir/lcv_media.so", "libno_such_library_lcv.so.7"}, "to test");
    FAIL() << "opened a missing library";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("/nonexistent/dir/lcv_media.so: ", 0), 0u) << what;
    EXPECT_NE(what.find("libno_such_library_lcv.so.7"), std::string::npos) << what;
    EXPECT_NE(what.find("to test"), std::string::npos) << what;
  }
}

TEST(SharedLibraryTest, TheMediaPluginExportsItsEntryAndMissingSymbolsAreNamed) {
  const std::string plugin = (fs::path(LCV_BINARY).parent_path() / "lcv_media.so").string();
  // Not the first candidate: a failing one before it is skipped.
  const SharedLibrary library = SharedLibrary::Open({"/nonexistent/lcv_media.so", plugin}, "to test");
  EXPECT_EQ(library.path(), plugin);
  EXPECT_NE(library.Symbol("lcv_media_backend"), nullptr);
  try {
    library.Symbol("lcv_no_such_symbol");
    FAIL() << "found a missing symbol";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind(plugin + ": ", 0), 0u) << what;
    EXPECT_NE(what.find("lcv_no_such_symbol"), std::string::npos) << what;
  }
}

TEST(SharedLibraryTest, ExecutableDirIsTheFolderOfThisTestProgram) {
  const std::string dir = ExecutableDir();
  ASSERT_FALSE(dir.empty());
  EXPECT_TRUE(fs::exists(fs::path(dir) / program_invocation_short_name)) << dir;
}

}  // namespace
}  // namespace lcv::mapping
