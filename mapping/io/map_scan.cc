// Pre-decoding structure scans of map files. nlohmann-json's MessagePack reader recurses once per
// nesting level and trusts declared lengths, so a hostile or corrupt file (a run of 0x91 bytes)
// could exhaust the stack: these scans bound the nesting and the lengths first, without
// recursion or allocation per element.
#include <cstdint>
#include <string>
#include <vector>

#include "mapping/io/map_internal.h"
#include "slam/util/error.h"

namespace lcv::mapping::internal {
namespace {

std::uint64_t ReadBigEndian(const unsigned char* p, int bytes) {
  std::uint64_t value = 0;
  for (int i = 0; i < bytes; ++i) value = value << 8 | p[i];
  return value;
}

}  // namespace

void CheckMessagePackStructure(const std::string& bytes, const std::string& source_name) {
  const auto* data = reinterpret_cast<const unsigned char*>(bytes.data());
  const std::uint64_t size = bytes.size();
  std::uint64_t pos = 0;
  // Values still expected by each open container (a map of n pairs expects 2n values).
  std::vector<std::uint64_t> open;
  auto fail = [&](const std::string& what) {
    throw InputError(source_name,
                     "invalid MessagePack at byte " + std::to_string(pos) + ": " + what);
  };
  auto need = [&](std::uint64_t count) {
    if (count > size - pos) fail("truncated file (a value runs past the end)");
  };
  bool root_done = false;
  while (!root_done) {
    need(1);
    const unsigned char type = data[pos];
    std::uint64_t skip = 1;      // bytes of this value besides its container elements
    std::uint64_t children = 0;  // values it contains
    bool container = false;
    auto sized = [&](int length_bytes, int header_extra) {
      need(1 + length_bytes);
      skip = 1 + length_bytes + header_extra + ReadBigEndian(data + pos + 1, length_bytes);
    };
    auto collection = [&](int length_bytes, std::uint64_t per_entry) {
      need(1 + length_bytes);
      skip = 1 + length_bytes;
      children = per_entry * ReadBigEndian(data + pos + 1, length_bytes);
      container = true;
    };
    if (type <= 0x7f || type >= 0xe0 || type == 0xc0 || type == 0xc2 || type == 0xc3) {
      skip = 1;
    } else if (type <= 0x8f) {
      children = 2 * (type & 0x0f);
      container = true;
    } else if (type <= 0x9f) {
      children = type & 0x0f;
      container = true;
    } else if (type <= 0xbf) {
      skip = 1 + (type & 0x1f);
    } else {
      // clang-format off
      switch (type) {
        case 0xc4: sized(1, 0); break;  // bin 8
        case 0xc5: sized(2, 0); break;  // bin 16
        case 0xc6: sized(4, 0); break;  // bin 32
        case 0xc7: sized(1, 1); break;  // ext 8 (+ type byte)
        case 0xc8: sized(2, 1); break;  // ext 16
        case 0xc9: sized(4, 1); break;  // ext 32
        case 0xca: skip = 5; break;     // float 32
        case 0xcb: skip = 9; break;     // float 64
        case 0xcc: case 0xd0: skip = 2; break;
        case 0xcd: case 0xd1: skip = 3; break;
        case 0xce: case 0xd2: skip = 5; break;
        case 0xcf: case 0xd3: skip = 9; break;
        case 0xd4: skip = 3; break;     // fixext 1
        case 0xd5: skip = 4; break;
        case 0xd6: skip = 6; break;
        case 0xd7: skip = 10; break;
        case 0xd8: skip = 18; break;
        case 0xd9: sized(1, 0); break;  // str 8
        case 0xda: sized(2, 0); break;  // str 16
        case 0xdb: sized(4, 0); break;  // str 32
        case 0xdc: collection(2, 1); break;
        case 0xdd: collection(4, 1); break;
        case 0xde: collection(2, 2); break;
        case 0xdf: collection(4, 2); break;
        default: fail("invalid type byte 0xc1");
      }
      // clang-format on
    }
    need(skip);
    pos += skip;
    if (container && children > 0) {
      // Every element takes at least one byte.
      if (children > size - pos) fail("truncated file (a container is longer than the file)");
      if (static_cast<int>(open.size()) >= kMaxMapNesting) fail("nesting too deep");
      open.push_back(children);
      continue;
    }
    // One value completed: close every container it completes.
    while (!open.empty() && --open.back() == 0) open.pop_back();
    root_done = open.empty();
  }
  if (pos != size) fail("trailing bytes after the map");
}

void CheckJsonNesting(const std::string& bytes, const std::string& source_name) {
  int depth = 0;
  bool in_string = false, escaped = false;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    const char c = bytes[i];
    if (in_string) {
      if (escaped) {
        escaped = false;
      } else if (c == '\\') {
        escaped = true;
      } else if (c == '"') {
        in_string = false;
      }
    } else if (c == '"') {
      in_string = true;
    } else if (c == '{' || c == '[') {
      if (++depth > kMaxMapNesting) {
        throw InputError(source_name,
                         "invalid JSON at byte " + std::to_string(i) + ": nesting too deep");
      }
    } else if (c == '}' || c == ']') {
      --depth;
    }
  }
}

}  // namespace lcv::mapping::internal
