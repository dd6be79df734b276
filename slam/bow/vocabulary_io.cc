// Vocabulary::Save / Load: the compact binary format documented in vocabulary.h.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <istream>
#include <ostream>
#include <string>

#include "slam/bow/vocabulary.h"
#include "slam/util/error.h"

namespace lcv::slam {
namespace {

constexpr char kMagic[8] = {'L', 'C', 'V', 'V', 'O', 'C', 'A', 'B'};
constexpr std::uint32_t kVersion = 1;
constexpr std::size_t kHeaderBytes = 8 + 4 * 4;
constexpr std::size_t kNodeBytes = 4 + 2 + 32 + 4;
constexpr std::size_t kChecksumBytes = 8;

std::uint64_t Fnv1a(const char* data, std::size_t size) {
  std::uint64_t hash = 1469598103934665603ull;
  for (std::size_t i = 0; i < size; ++i) {
    hash ^= static_cast<unsigned char>(data[i]);
    hash *= 1099511628211ull;
  }
  return hash;
}

// Little-endian encoding whatever the host order.
template <typename T>
void Put(std::string* out, T value) {
  for (std::size_t i = 0; i < sizeof(T); ++i) {
    out->push_back(static_cast<char>((static_cast<std::uint64_t>(value) >> (8 * i)) & 0xff));
  }
}

template <typename T>
T Get(const char* data) {
  std::uint64_t value = 0;
  for (std::size_t i = 0; i < sizeof(T); ++i) {
    value |= static_cast<std::uint64_t>(static_cast<unsigned char>(data[i])) << (8 * i);
  }
  return static_cast<T>(value);
}

}  // namespace

void Vocabulary::Save(std::ostream& out) const {
  std::string bytes;
  bytes.reserve(kHeaderBytes + num_nodes() * kNodeBytes + kChecksumBytes);
  bytes.append(kMagic, sizeof(kMagic));
  Put<std::uint32_t>(&bytes, kVersion);
  Put<std::uint32_t>(&bytes, static_cast<std::uint32_t>(branching_));
  Put<std::uint32_t>(&bytes, static_cast<std::uint32_t>(depth_));
  Put<std::uint32_t>(&bytes, static_cast<std::uint32_t>(num_nodes()));
  for (std::size_t node = 0; node < num_nodes(); ++node) {
    Put<std::uint32_t>(&bytes, node_first_child_[node]);
    Put<std::uint16_t>(&bytes, node_num_children_[node]);
    bytes.append(reinterpret_cast<const char*>(node_descriptor_[node].data()), 32);
    std::uint32_t weight_bits;
    std::memcpy(&weight_bits, &node_weight_[node], 4);
    Put<std::uint32_t>(&bytes, weight_bits);
  }
  Put<std::uint64_t>(&bytes, Fnv1a(bytes.data(), bytes.size()));
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

Vocabulary Vocabulary::Load(std::istream& in, const std::string& source_name) {
  const auto fail = [&source_name](const std::string& what) {
    return InputError(source_name, "vocabulary: " + what);
  };
  const auto node_fail = [&fail](std::uint64_t node, const char* what) {
    return fail("node " + std::to_string(node) + ": " + what);
  };
  std::string bytes;
  {
    // Block reads: an istreambuf_iterator copy runs at a few MB/s on 40 MB files.
    std::vector<char> block(1 << 20);
    while (in.read(block.data(), static_cast<std::streamsize>(block.size())) || in.gcount() > 0) {
      bytes.append(block.data(), static_cast<std::size_t>(in.gcount()));
    }
  }
  if (bytes.size() < sizeof(kMagic) || std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0) {
    throw fail("not a vocabulary file (magic \"LCVVOCAB\" missing)");
  }
  if (bytes.size() < kHeaderBytes) throw fail("truncated header");
  const char* header = bytes.data() + sizeof(kMagic);
  const std::uint32_t version = Get<std::uint32_t>(header);
  if (version != kVersion) {
    throw fail("version " + std::to_string(version) + " is not supported (this build reads " +
               std::to_string(kVersion) + ")");
  }
  const std::uint32_t branching = Get<std::uint32_t>(header + 4);
  const std::uint32_t depth = Get<std::uint32_t>(header + 8);
  const std::uint64_t num_nodes = Get<std::uint32_t>(header + 12);
  const std::uint64_t expected = kHeaderBytes + num_nodes * kNodeBytes + kChecksumBytes;
  if (bytes.size() < expected) {
    throw fail("truncated: " + std::to_string(num_nodes) + " nodes need " +
               std::to_string(expected) + " bytes, the file has " +
               std::to_string(bytes.size()));
  }
  if (bytes.size() > expected) {
    throw fail(std::to_string(bytes.size() - expected) + " unexpected bytes after the checksum");
  }
  const std::size_t payload = expected - kChecksumBytes;
  if (Get<std::uint64_t>(bytes.data() + payload) != Fnv1a(bytes.data(), payload)) {
    throw fail("checksum mismatch (the file is corrupted)");
  }
  if (num_nodes == 0) return Vocabulary();  // what an empty vocabulary saves
  VocabularyOptions options;
  options.branching = static_cast<int>(std::min<std::uint32_t>(branching, 1u << 30));
  options.depth = static_cast<int>(std::min<std::uint32_t>(depth, 1u << 30));
  if (const auto problem = options.Problem()) throw fail(*problem);

  Vocabulary vocabulary;
  vocabulary.branching_ = options.branching;
  vocabulary.depth_ = options.depth;
  vocabulary.node_descriptor_.resize(num_nodes);
  vocabulary.node_first_child_.resize(num_nodes);
  vocabulary.node_num_children_.resize(num_nodes);
  vocabulary.node_weight_.resize(num_nodes);
  std::vector<std::uint8_t> level(num_nodes, 0);
  std::vector<std::uint8_t> has_parent(num_nodes, 0);
  const char* node_bytes = bytes.data() + kHeaderBytes;
  for (std::uint64_t node = 0; node < num_nodes; ++node, node_bytes += kNodeBytes) {
    const std::uint32_t first_child = Get<std::uint32_t>(node_bytes);
    const std::uint16_t num_children = Get<std::uint16_t>(node_bytes + 4);
    std::memcpy(vocabulary.node_descriptor_[node].data(), node_bytes + 6, 32);
    const std::uint32_t weight_bits = Get<std::uint32_t>(node_bytes + 38);
    float weight;
    std::memcpy(&weight, &weight_bits, 4);
    if (node > 0 && !has_parent[node]) throw node_fail(node, "is nobody's child");
    if (!std::isfinite(weight) || weight < 0.0f) throw node_fail(node, "bad weight");
    if ((num_children == 0) != (first_child == 0)) {
      throw node_fail(node, "first_child and num_children disagree");
    }
    if (num_children > 0) {
      // Children after their parent: the tree has no cycles, and levels are known in order.
      if (first_child <= node || first_child + std::uint64_t{num_children} > num_nodes) {
        throw node_fail(node, "children out of range");
      }
      if (num_children > branching) throw node_fail(node, "more children than the branching");
      if (level[node] >= depth) throw node_fail(node, "deeper than the vocabulary's depth");
      if (weight != 0.0f) throw node_fail(node, "an inner node has a weight");
      for (std::uint32_t child = first_child; child < first_child + num_children; ++child) {
        if (has_parent[child]) throw node_fail(child, "two parents");
        has_parent[child] = 1;
        level[child] = static_cast<std::uint8_t>(level[node] + 1);
      }
    }
    vocabulary.node_first_child_[node] = first_child;
    vocabulary.node_num_children_[node] = num_children;
    vocabulary.node_weight_[node] = weight;
  }
  vocabulary.IndexWords();
  return vocabulary;
}

}  // namespace lcv::slam
