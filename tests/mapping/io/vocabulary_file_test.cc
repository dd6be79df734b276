#include "mapping/io/vocabulary_file.h"

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "slam/util/error.h"
#include "tests/slam/bow/synthetic_descriptors.h"

namespace lcv::mapping {
namespace {

namespace fs = std::filesystem;

class VocabularyFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("lcv_vocabulary_file_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    // A small vocabulary of 30 clusters of noisy copies, over 6 images.
    std::mt19937_64 rng(17);
    std::vector<slam::OrbDescriptor> prototypes;
    for (int c = 0; c < 30; ++c) prototypes.push_back(slam::test::RandomDescriptor(rng));
    images_.resize(6);
    for (int copy = 0; copy < 12; ++copy) {
      for (int c = 0; c < 30; ++c) {
        images_[(copy + c) % 6].push_back(slam::test::FlipBits(prototypes[c], 10, rng));
      }
    }
    slam::VocabularyOptions options;
    options.branching = 5;
    options.depth = 3;
    vocabulary_ = slam::Vocabulary::Train(images_, options);
    std::ostringstream out;
    vocabulary_.Save(out);
    bytes_ = out.str();
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Write(const std::string& name, const std::string& bytes) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
  }

  // Expects ReadVocabularyFile(path) to throw an InputError whose message starts with the path
  // and contains fragment.
  static void ExpectInputError(const std::string& path, const std::string& fragment) {
    try {
      ReadVocabularyFile(path);
      ADD_FAILURE() << "no error for " << path;
    } catch (const InputError& e) {
      const std::string message = e.what();
      EXPECT_EQ(message.rfind(path, 0), 0u) << message;
      EXPECT_NE(message.find(fragment), std::string::npos) << message;
    }
  }

  fs::path dir_;
  std::vector<std::vector<slam::OrbDescriptor>> images_;
  slam::Vocabulary vocabulary_;
  std::string bytes_;
};

TEST_F(VocabularyFileTest, ReadsWhatSaveWrote) {
  const std::string path = Write("small.lcvoc", bytes_);
  const std::shared_ptr<const slam::Vocabulary> read = ReadVocabularyFile(path);
  ASSERT_NE(read, nullptr);
  EXPECT_EQ(read->branching(), 5);
  EXPECT_EQ(read->depth(), 3);
  EXPECT_EQ(read->num_nodes(), vocabulary_.num_nodes());
  ASSERT_EQ(read->num_words(), vocabulary_.num_words());
  for (slam::WordId w = 0; w < read->num_words(); ++w) {
    EXPECT_EQ(read->WordWeight(w), vocabulary_.WordWeight(w));
  }
  for (const auto& image : images_) {
    for (const slam::OrbDescriptor& d : image) EXPECT_EQ(read->WordOf(d), vocabulary_.WordOf(d));
  }
}

TEST_F(VocabularyFileTest, MissingFileNamesThePath) {
  ExpectInputError((dir_ / "absent.lcvoc").string(), "");
}

TEST_F(VocabularyFileTest, TruncatedFileIsRejected) {
  // Cut inside the node records, and just before the checksum's last byte.
  ExpectInputError(Write("cut_nodes.lcvoc", bytes_.substr(0, bytes_.size() / 2)), "truncated");
  ExpectInputError(Write("cut_checksum.lcvoc", bytes_.substr(0, bytes_.size() - 1)), "truncated");
  ExpectInputError(Write("empty.lcvoc", ""), "not a vocabulary file");
}

TEST_F(VocabularyFileTest, CorruptedFileIsRejected) {
  std::string flipped = bytes_;
  flipped[bytes_.size() / 2] ^= 0x10;  // inside a node: only the checksum can tell
  ExpectInputError(Write("flipped.lcvoc", flipped), "checksum");
  std::mt19937_64 rng(5);
  std::string garbage(4096, '\0');
  for (char& c : garbage) c = static_cast<char>(rng() & 0xff);
  ExpectInputError(Write("garbage.lcvoc", garbage), "not a vocabulary file");
  ExpectInputError(Write("text.lcvoc", "this is not a vocabulary\n"), "not a vocabulary file");
}

TEST_F(VocabularyFileTest, VocabularyWithoutWordsIsRejected) {
  std::ostringstream out;
  slam::Vocabulary().Save(out);
  ExpectInputError(Write("no_words.lcvoc", out.str()), "");
}

TEST(DefaultVocabularyPath, EnvironmentOverridesTheShippedFile) {
  const char* saved = std::getenv("LCV_VOCABULARY");
  const std::string saved_value = saved ? saved : "";
  ::unsetenv("LCV_VOCABULARY");
  const std::string shipped = DefaultVocabularyPath();
  EXPECT_TRUE(fs::path(shipped).is_absolute()) << shipped;
  EXPECT_EQ(fs::path(shipped).filename(), "orb_synth.lcvoc");
  EXPECT_EQ(fs::path(shipped).parent_path().filename(), "vocabulary");
  ::setenv("LCV_VOCABULARY", "", 1);  // empty counts as unset
  EXPECT_EQ(DefaultVocabularyPath(), shipped);
  ::setenv("LCV_VOCABULARY", "/somewhere/else.lcvoc", 1);
  EXPECT_EQ(DefaultVocabularyPath(), "/somewhere/else.lcvoc");
  if (saved) {
    ::setenv("LCV_VOCABULARY", saved_value.c_str(), 1);
  } else {
    ::unsetenv("LCV_VOCABULARY");
  }
}

}  // namespace
}  // namespace lcv::mapping
