// Fuzz-style robustness of the map reader: thousands of mutated and truncated map files, in both
// encodings. Every input must either parse into a map that passes validation, or be rejected with
// lcv::InputError naming the file. Anything else (another exception type, a crash, a hang)
// fails the test.
#include <gtest/gtest.h>

#include <random>

#include "mapping/io/map_file.h"
#include "mapping/line_cloud.h"
#include "mapping/synthetic_map.h"
#include "slam/util/error.h"

namespace lcv::mapping {
namespace {

constexpr const char* kSource = "fuzz.lcmap";

struct Outcome {
  int accepted = 0;
  int rejected = 0;
};

void Feed(const std::string& bytes, Outcome* outcome, std::uint64_t seed, int trial) {
  try {
    const slam::Map map = ParseMap(bytes, kSource);
    ValidateMap(map, kSource);  // an accepted map upholds every invariant
    SerializeMap(map, MapEncoding::kMessagePack);
    ++outcome->accepted;
  } catch (const InputError& e) {
    const std::string message = e.what();
    ASSERT_EQ(message.rfind(std::string(kSource) + ": ", 0), 0u)
        << "seed " << seed << " trial " << trial << ": " << message;
    ++outcome->rejected;
  } catch (const std::exception& e) {
    FAIL() << "seed " << seed << " trial " << trial << ": unexpected exception " << e.what();
  }
}

// Small maps so that thousands of parses take a second or two.
std::vector<std::string> Corpus() {
  SyntheticMapOptions o;
  o.num_points = 25;
  o.num_keyframes = 4;
  o.seed = 99;
  const slam::Map point_map = MakeSyntheticPointMap(o);
  const slam::Map line_cloud = ConvertToLineCloud(point_map, LineCloudOptions{5});
  return {SerializeMap(point_map, MapEncoding::kJson),
          SerializeMap(point_map, MapEncoding::kMessagePack),
          SerializeMap(line_cloud, MapEncoding::kJson),
          SerializeMap(line_cloud, MapEncoding::kMessagePack)};
}

std::string Mutate(const std::string& original, std::mt19937_64& rng) {
  std::string bytes = original;
  auto position = [&](size_t size) {
    return std::uniform_int_distribution<size_t>(0, size ? size - 1 : 0)(rng);
  };
  auto random_byte = [&] {
    // Bias towards bytes that matter to the formats: digits, brackets, MessagePack type bytes.
    static const char kInteresting[] =
        "0123456789-.eE[]{},:\"\\ntf\x80\x90\xc0\xc1\xcb\xdc\xdd\xde\xdf\xff";
    if (rng() % 2) return kInteresting[rng() % (sizeof(kInteresting) - 1)];
    return static_cast<char>(rng() & 0xff);
  };
  const int edits = 1 + static_cast<int>(rng() % 4);
  for (int e = 0; e < edits && !bytes.empty(); ++e) {
    switch (rng() % 5) {
      case 0:  // overwrite a byte
        bytes[position(bytes.size())] = random_byte();
        break;
      case 1:  // flip one bit
        bytes[position(bytes.size())] ^= static_cast<char>(1u << (rng() % 8));
        break;
      case 2:  // insert a byte
        bytes.insert(bytes.begin() + position(bytes.size() + 1), random_byte());
        break;
      case 3:  // delete a run
        bytes.erase(position(bytes.size()), 1 + rng() % 8);
        break;
      case 4:  // truncate
        bytes.resize(position(bytes.size()));
        break;
    }
  }
  return bytes;
}

TEST(MapFileFuzz, MutatedFilesAreAcceptedOrRejectedCleanly) {
  const std::vector<std::string> corpus = Corpus();
  const std::uint64_t seed = 20240521;
  std::mt19937_64 rng(seed);
  Outcome outcome;
  const int trials = 4000;
  for (int trial = 0; trial < trials; ++trial) {
    const std::string& original = corpus[trial % corpus.size()];
    Feed(Mutate(original, rng), &outcome, seed, trial);
    if (HasFatalFailure()) return;
  }
  EXPECT_EQ(outcome.accepted + outcome.rejected, trials);
  // Most random edits break a map; a few (a digit in a coordinate) legitimately do not.
  EXPECT_GT(outcome.rejected, trials / 2);
  std::printf("fuzz: %d accepted, %d rejected\n", outcome.accepted, outcome.rejected);
}

TEST(MapFileFuzz, EveryTruncationIsRejected) {
  const std::vector<std::string> corpus = Corpus();
  for (const std::string& original : corpus) {
    // Every strict prefix of a MessagePack map is incomplete; a JSON prefix is incomplete until
    // its closing brace.
    const size_t complete = original[0] == '{' ? original.rfind('}') + 1 : original.size();
    const size_t step = std::max<size_t>(1, complete / 1500);
    for (size_t length = 0; length < complete; length += step) {
      try {
        ParseMap(original.substr(0, length), kSource);
        ADD_FAILURE() << "accepted a prefix of " << length << " of " << original.size() << " bytes";
        return;
      } catch (const InputError& e) {
        EXPECT_EQ(std::string(e.what()).rfind(std::string(kSource) + ": ", 0), 0u);
      }
    }
  }
}

TEST(MapFileFuzz, RandomBytesAreRejected) {
  std::mt19937_64 rng(7);
  for (int trial = 0; trial < 2000; ++trial) {
    std::string bytes(rng() % 200, '\0');
    for (char& c : bytes) c = static_cast<char>(rng() & 0xff);
    // Half of them look like a MessagePack map or a JSON object to get past the first check.
    if (trial % 2 && !bytes.empty()) bytes[0] = (trial % 4 == 1) ? '{' : static_cast<char>(0x85);
    EXPECT_THROW(ParseMap(bytes, kSource), InputError) << "trial " << trial;
  }
}

}  // namespace
}  // namespace lcv::mapping
