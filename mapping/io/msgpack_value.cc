#include "mapping/io/msgpack_value.h"

#include <cmath>
#include <cstdio>
#include <cstring>

namespace lcv::mapping::internal {
namespace {

inline std::uint64_t ReadBigEndian(const unsigned char* p, int bytes) {
  std::uint64_t value = 0;
  for (int i = 0; i < bytes; ++i) value = value << 8 | p[i];
  return value;
}

// Per type byte: how to size a value without its nested elements (a table: End() runs over every
// value of a large file, so this is the decoder's hot loop).
struct TypeInfo {
  std::uint8_t fixed = 0;         // total size when known from the type byte, else 0
  std::uint8_t length_bytes = 0;  // big-endian length after the type byte (str/bin/ext/containers)
  std::uint8_t extra = 0;         // bytes between length and payload (the ext type byte)
  std::uint8_t children = 0;      // 0: none; 1: array (n elements); 2: map (2n values)
};

struct TypeTable {
  TypeInfo info[256];
  TypeTable() {
    for (int t = 0; t < 256; ++t) {
      TypeInfo& i = info[t];
      if (t <= 0x7f || t >= 0xe0 || t == 0xc0 || t == 0xc1 || t == 0xc2 || t == 0xc3) {
        i.fixed = 1;
      } else if (t <= 0x8f) {
        i.fixed = 1, i.children = 2;
      } else if (t <= 0x9f) {
        i.fixed = 1, i.children = 1;
      } else if (t <= 0xbf) {
        i.fixed = static_cast<std::uint8_t>(1 + (t & 0x1f));
      }
    }
    const auto sized = [&](int t, int length_bytes, int extra) {
      info[t].length_bytes = static_cast<std::uint8_t>(length_bytes);
      info[t].extra = static_cast<std::uint8_t>(extra);
    };
    sized(0xc4, 1, 0), sized(0xc5, 2, 0), sized(0xc6, 4, 0);  // bin
    sized(0xc7, 1, 1), sized(0xc8, 2, 1), sized(0xc9, 4, 1);  // ext
    sized(0xd9, 1, 0), sized(0xda, 2, 0), sized(0xdb, 4, 0);  // str
    info[0xca].fixed = 5, info[0xcb].fixed = 9;
    info[0xcc].fixed = info[0xd0].fixed = 2;
    info[0xcd].fixed = info[0xd1].fixed = 3;
    info[0xce].fixed = info[0xd2].fixed = 5;
    info[0xcf].fixed = info[0xd3].fixed = 9;
    info[0xd4].fixed = 3, info[0xd5].fixed = 4, info[0xd6].fixed = 6;
    info[0xd7].fixed = 10, info[0xd8].fixed = 18;
    info[0xdc] = {3, 2, 0, 1}, info[0xdd] = {5, 4, 0, 1};
    info[0xde] = {3, 2, 0, 2}, info[0xdf] = {5, 4, 0, 2};
  }
};

const TypeTable kTypes;  // built at load time: no initialization guard in the hot loop

// Bytes of the value at p without nested elements: scalars whole, strings/binary with their
// payload, containers their header only. *children: nested values that follow.
inline std::size_t FlatSize(const unsigned char* p, std::uint64_t* children) {
  const TypeInfo& info = kTypes.info[*p];
  if (info.children) {
    const std::uint64_t n = info.length_bytes ? ReadBigEndian(p + 1, info.length_bytes) : *p & 0x0f;
    *children = n * info.children;
    return info.fixed;
  }
  *children = 0;
  if (info.fixed) return info.fixed;
  return 1 + info.length_bytes + info.extra + ReadBigEndian(p + 1, info.length_bytes);
}

std::string FormatDouble(double value) {
  if (!std::isfinite(value)) return "null";  // as nlohmann dumps NaN and infinity
  char text[32];
  for (int digits = 15; digits <= 17; ++digits) {
    std::snprintf(text, sizeof text, "%.*g", digits, value);
    if (std::strtod(text, nullptr) == value) break;
  }
  std::string out = text;
  if (out.find_first_of(".e") == std::string::npos) out += ".0";
  return out;
}

void AppendJson(const MsgpackValue& v, std::size_t max_chars, std::string* out) {
  if (out->size() > max_chars) return;
  if (v.is_null()) {
    *out += "null";
  } else if (v.is_object()) {
    *out += '{';
    MsgpackValue key = v.size() ? v.FirstElement() : MsgpackValue();
    for (std::uint64_t i = 0; i < v.size() && out->size() <= max_chars; ++i) {
      if (i) *out += ',';
      AppendJson(key, max_chars, out);
      *out += ':';
      const MsgpackValue value = key.Next();
      AppendJson(value, max_chars, out);
      key = value.Next();
    }
    *out += '}';
  } else if (v.is_array()) {
    *out += '[';
    MsgpackValue element = v.size() ? v.FirstElement() : MsgpackValue();
    for (std::uint64_t i = 0; i < v.size() && out->size() <= max_chars; ++i) {
      if (i) *out += ',';
      AppendJson(element, max_chars, out);
      element = element.Next();
    }
    *out += ']';
  } else if (v.is_string()) {
    *out += '"';
    for (const char c : v.bytes()) {
      if (c == '"' || c == '\\') *out += '\\';
      *out += static_cast<unsigned char>(c) < 0x20 ? '?' : c;
    }
    *out += '"';
  } else if (v.is_binary()) {
    *out += "binary data";
  } else if (v.is_number_unsigned()) {
    *out += std::to_string(v.as_unsigned());
  } else if (v.is_number_integer()) {
    *out += std::to_string(v.as_integer());
  } else if (v.is_number()) {
    *out += FormatDouble(v.as_double());
  } else {
    *out += *reinterpret_cast<const unsigned char*>(v.Raw()) == 0xc3 ? "true" : "false";
  }
}

}  // namespace

std::uint64_t MsgpackValue::size() const {
  const unsigned char t = *p_;
  if ((t & 0xe0) == 0x80) return t & 0x0f;  // fixmap, fixarray
  if (t == 0xdc || t == 0xde) return ReadBigEndian(p_ + 1, 2);
  if (t == 0xdd || t == 0xdf) return ReadBigEndian(p_ + 1, 4);
  return 0;
}

double MsgpackValue::as_double() const {
  const unsigned char t = *p_;
  if (t == 0xca) {
    const std::uint32_t bits = static_cast<std::uint32_t>(ReadBigEndian(p_ + 1, 4));
    float value;
    std::memcpy(&value, &bits, 4);
    return value;
  }
  if (t == 0xcb) {
    const std::uint64_t bits = ReadBigEndian(p_ + 1, 8);
    double value;
    std::memcpy(&value, &bits, 8);
    return value;
  }
  return is_number_unsigned() ? static_cast<double>(as_unsigned())
                              : static_cast<double>(as_integer());
}

std::uint64_t MsgpackValue::as_unsigned() const {
  const unsigned char t = *p_;
  if (t <= 0x7f) return t;
  switch (t) {
    case 0xcc: return p_[1];
    case 0xcd: return ReadBigEndian(p_ + 1, 2);
    case 0xce: return ReadBigEndian(p_ + 1, 4);
    case 0xcf: return ReadBigEndian(p_ + 1, 8);
    default: break;
  }
  if (t == 0xca || t == 0xcb) return static_cast<std::uint64_t>(as_double());
  return static_cast<std::uint64_t>(as_integer());
}

std::int64_t MsgpackValue::as_integer() const {
  const unsigned char t = *p_;
  if (t >= 0xe0) return static_cast<std::int8_t>(t);
  switch (t) {
    case 0xd0: return static_cast<std::int8_t>(p_[1]);
    case 0xd1: return static_cast<std::int16_t>(ReadBigEndian(p_ + 1, 2));
    case 0xd2: return static_cast<std::int32_t>(ReadBigEndian(p_ + 1, 4));
    case 0xd3: return static_cast<std::int64_t>(ReadBigEndian(p_ + 1, 8));
    default: break;
  }
  if (t == 0xca || t == 0xcb) return static_cast<std::int64_t>(as_double());
  return static_cast<std::int64_t>(as_unsigned());
}

std::string_view MsgpackValue::bytes() const {
  const unsigned char t = *p_;
  const auto view = [&](std::size_t header, std::uint64_t length) {
    return std::string_view(reinterpret_cast<const char*>(p_ + header), length);
  };
  if ((t & 0xe0) == 0xa0) return view(1, t & 0x1f);
  switch (t) {
    case 0xd9: case 0xc4: return view(2, p_[1]);
    case 0xda: case 0xc5: return view(3, ReadBigEndian(p_ + 1, 2));
    case 0xdb: case 0xc6: return view(5, ReadBigEndian(p_ + 1, 4));
    case 0xc7: return view(3, p_[1]);  // ext: length, ext type, payload
    case 0xc8: return view(4, ReadBigEndian(p_ + 1, 2));
    case 0xc9: return view(6, ReadBigEndian(p_ + 1, 4));
    case 0xd4: return view(2, 1);  // fixext: ext type, payload
    case 0xd5: return view(2, 2);
    case 0xd6: return view(2, 4);
    case 0xd7: return view(2, 8);
    case 0xd8: return view(2, 16);
    default: return {};
  }
}

std::size_t MsgpackValue::HeaderSize() const {
  std::uint64_t children;
  return FlatSize(p_, &children);
}

MsgpackValue MsgpackValue::FirstElement() const { return MsgpackValue(p_ + HeaderSize()); }

const unsigned char* MsgpackValue::End() const {
  const unsigned char* p = p_;
  std::uint64_t remaining = 1;
  while (remaining > 0) {
    --remaining;
    std::uint64_t children;
    p += FlatSize(p, &children);
    remaining += children;
  }
  return p;
}

MsgpackValue::Members MsgpackValue::MembersOf() const {
  Members members;
  const std::uint64_t n = size();
  members.entries_.reserve(n);
  MsgpackValue key = n ? FirstElement() : MsgpackValue();
  for (std::uint64_t i = 0; i < n; ++i) {
    if (!key.is_string()) throw MsgpackFormatError("map key is not a string");
    const MsgpackValue value = key.Next();
    members.entries_.emplace_back(key.bytes(), value);
    if (i + 1 < n) key = value.Next();
  }
  return members;
}

MsgpackValue MsgpackValue::Members::Find(std::string_view key) const {
  for (auto it = entries_.rbegin(); it != entries_.rend(); ++it) {
    if (it->first == key) return it->second;
  }
  return MsgpackValue();
}

std::string MsgpackValue::Describe(std::size_t max_chars) const {
  std::string out;
  AppendJson(*this, max_chars, &out);
  return out;
}

}  // namespace lcv::mapping::internal
