// WriteFileAtomically: the target appears complete or not at all, a failed writer leaves the old
// file, and device targets (/dev/null) are written in place, never replaced.
#include "mapping/io/atomic_file.h"

#include <sys/stat.h>

#include <filesystem>
#include <stdexcept>

#include <gtest/gtest.h>

#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

std::filesystem::path TempDir() {
  const auto dir = std::filesystem::temp_directory_path() / "lcv_atomic_file_test";
  std::filesystem::create_directories(dir);
  return dir;
}

TEST(AtomicFileTest, WritesAndReplaces) {
  const std::string path = (TempDir() / "a.txt").string();
  WriteFileAtomically(path, "first");
  EXPECT_EQ(ReadFileBytes(path), "first");
  WriteFileAtomically(path, "second");
  EXPECT_EQ(ReadFileBytes(path), "second");
}

TEST(AtomicFileTest, FailingWriterKeepsTheOldFileAndLeavesNoTemporary) {
  const std::filesystem::path dir = TempDir() / "failing";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "b.txt").string();
  WriteFileAtomically(path, "kept");
  EXPECT_THROW(WriteFileAtomically(path,
                                   [](std::ostream& out) {
                                     out << "partial";
                                     throw std::runtime_error("writer failed");
                                   }),
               std::runtime_error);
  EXPECT_EQ(ReadFileBytes(path), "kept");
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    (void)entry;
    ++files;
  }
  EXPECT_EQ(files, 1);
}

TEST(AtomicFileTest, DeviceTargetIsWrittenInPlaceNotReplaced) {
  WriteFileAtomically("/dev/null", "discarded");
  struct stat info;
  ASSERT_EQ(::stat("/dev/null", &info), 0);
  EXPECT_TRUE(S_ISCHR(info.st_mode)) << "/dev/null was replaced by a regular file";
}

TEST(AtomicFileTest, MissingFolderNamesThePath) {
  const std::string path = (TempDir() / "no" / "such" / "folder" / "c.txt").string();
  try {
    WriteFileAtomically(path, "x");
    FAIL() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace lcv::mapping
