// Replays the committed corpus of mutated inputs (fuzz/corpus/<reader>/, made by
// fuzz/make_corpus.py from seeds written by the project's own commands) through every reader of
// untrusted input. Each input must be accepted, or refused with lcv::InputError naming the
// input; any other exception fails the test, and a crash or hang fails the ctest run. The count
// is bounded (no timing), so the test is quick and deterministic; the libFuzzer targets behind
// -DLCV_FUZZ=ON explore further (README, Development).
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "fuzz/fuzz_readers.h"

namespace lcv::fuzz {
namespace {

namespace fs = std::filesystem;

const fs::path kCorpus = fs::path(LCV_SOURCE_DIR) / "fuzz" / "corpus";

std::string ReadAll(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

std::vector<fs::path> CorpusFiles(const std::string& reader) {
  std::vector<fs::path> files;
  const fs::path dir = kCorpus / reader;
  if (!fs::is_directory(dir)) return files;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.is_regular_file()) files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

class CorpusReplay : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    scratch_ = (fs::temp_directory_path() / ("lcv_corpus_replay_" + std::to_string(::getpid())))
                   .string();
    PrepareScratch(scratch_);
  }
  void TearDown() override { fs::remove_all(scratch_); }
  std::string scratch_;
};

TEST_P(CorpusReplay, EveryInputIsAcceptedOrRefusedByName) {
  const std::string reader = GetParam();
  const std::vector<fs::path> files = CorpusFiles(reader);
  // A few hundred files in all; each reader has its seeds and their mutations.
  ASSERT_GE(files.size(), 10u) << "corpus of " << reader << " missing: " << kCorpus / reader;
  ASSERT_LE(files.size(), 400u);
  int accepted = 0, refused = 0;
  for (const fs::path& file : files) {
    SCOPED_TRACE(file.string());
    try {
      ReadOne(reader, ReadAll(file), scratch_);
      ++accepted;
    } catch (const InputError& e) {
      EXPECT_TRUE(NamesInput(e.what(), scratch_)) << "the error names no input: " << e.what();
      ++refused;
    } catch (const std::exception& e) {
      ADD_FAILURE() << "not an InputError: " << e.what();
    }
  }
  // Seeds are valid inputs: a corpus that only holds refused files tests only the first checks.
  EXPECT_GT(accepted, 0) << reader;
  EXPECT_GT(refused, 0) << reader;
  std::printf("%s: %zu inputs, %d accepted, %d refused\n", reader.c_str(), files.size(),
              accepted, refused);
}

// fuzz/readers.txt names the libFuzzer targets (fuzz/CMakeLists.txt): the same readers as here,
// each with a corpus folder.
TEST(CorpusReplayReaders, FuzzTargetsCorpusFoldersAndEntryPointsAgree) {
  std::ifstream list(fs::path(LCV_SOURCE_DIR) / "fuzz" / "readers.txt");
  std::vector<std::string> listed;
  for (std::string name; std::getline(list, name);) {
    if (!name.empty()) listed.push_back(name);
  }
  EXPECT_EQ(listed, ReaderNames());
  for (const std::string& reader : ReaderNames()) {
    EXPECT_TRUE(fs::is_directory(kCorpus / reader)) << reader;
  }
}

INSTANTIATE_TEST_SUITE_P(Readers, CorpusReplay, ::testing::ValuesIn(ReaderNames()),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace lcv::fuzz
