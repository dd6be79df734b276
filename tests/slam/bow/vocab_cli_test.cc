// `lcv vocab train` and `lcv vocab info` through the built binary: both spellings of the image
// folders, the summary, and the exit codes of bad input (1) and bad usage (2).
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "tests/support/cli_run.h"

namespace lcv {
namespace {

namespace fs = std::filesystem;

class VocabCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lcv_vocab_cli_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  test::CliResult Run(const std::string& arguments) const {
    return test::RunLcv(arguments, dir_.string());
  }
  static std::string Bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream out;
    out << in.rdbuf();
    return out.str();
  }

  fs::path dir_;
};

TEST_F(VocabCliTest, TrainsOnSeveralFoldersAndInfoReadsIt) {
  ASSERT_EQ(Run("synth --scenario desk --frames 3 --size 320x180 --seed 4 --out " + Path("desk"))
                .exit_code,
            0);
  const std::string map = Path("desk/map/images"), client = Path("desk/client/images");
  const std::string shape = " --branching 4 --depth 3 --features 500";
  const test::CliResult listed = Run("vocab train --images " + map + " " + client + shape +
                                     " --out " + Path("listed.lcvoc"));
  ASSERT_EQ(listed.exit_code, 0) << listed.err;
  EXPECT_NE(listed.out.find("trained on: 6 images"), std::string::npos) << listed.out;
  const test::CliResult repeated = Run("vocab train --images " + map + " --images=" + client +
                                       shape + " --out " + Path("repeated.lcvoc"));
  ASSERT_EQ(repeated.exit_code, 0) << repeated.err;
  // Same images, same options: the same file, whichever way the folders were given.
  EXPECT_EQ(Bytes(Path("listed.lcvoc")), Bytes(Path("repeated.lcvoc")));

  const test::CliResult info = Run("vocab info " + Path("listed.lcvoc"));
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_NE(info.out.find("K=4, L=3"), std::string::npos) << info.out;
  EXPECT_NE(info.out.find("loaded in: "), std::string::npos) << info.out;
}

TEST_F(VocabCliTest, BadInputAndUsage) {
  std::ofstream(Path("garbage.lcvoc")) << "not a vocabulary";
  const test::CliResult garbage = Run("vocab info " + Path("garbage.lcvoc"));
  EXPECT_EQ(garbage.exit_code, 1);
  EXPECT_NE(garbage.err.find(Path("garbage.lcvoc")), std::string::npos) << garbage.err;
  const test::CliResult missing = Run("vocab info " + Path("absent.lcvoc"));
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find(Path("absent.lcvoc")), std::string::npos) << missing.err;
  fs::create_directories(Path("empty"));
  const test::CliResult no_images =
      Run("vocab train --images " + Path("empty") + " --out " + Path("x.lcvoc"));
  EXPECT_EQ(no_images.exit_code, 1);
  EXPECT_NE(no_images.err.find("no images"), std::string::npos) << no_images.err;
  EXPECT_EQ(Run("vocab train --out " + Path("x.lcvoc")).exit_code, 2);
  EXPECT_EQ(Run("vocab train --images").exit_code, 2);
  EXPECT_EQ(Run("vocab train --images " + Path("empty") + " --branching 1 --out " + Path("x.lcvoc"))
                .exit_code,
            2);
  EXPECT_FALSE(fs::exists(Path("x.lcvoc")));
}

}  // namespace
}  // namespace lcv
