#pragma once
// Read-only views of values inside a MessagePack buffer, for decoding large map files without
// building a DOM (nlohmann-json's DOM costs ~1 s per 30 MB map: one allocation per number).
//
// Precondition: the buffer passed CheckMessagePackStructure (map_internal.h), so every declared
// length fits the buffer and nesting is bounded; the views then never read out of bounds. They
// refer to the buffer, which must outlive them. Type predicates follow nlohmann-json's reading of
// MessagePack, so that both decoders accept and reject the same files: positive fixint and
// uint 8..64 are unsigned; int 8..64 and negative fixint are signed (even when non-negative);
// ext types are binary (payload without the ext type byte). A map key that is not a string makes
// MembersOf throw MsgpackFormatError (nlohmann rejects such a file while parsing).
//
// Thread safety: immutable views; any number may be used concurrently.

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace lcv::mapping::internal {

class MsgpackFormatError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class MsgpackValue {
 public:
  MsgpackValue() = default;
  explicit MsgpackValue(const unsigned char* data) : p_(data) {}

  bool is_null() const { return *p_ == 0xc0; }
  bool is_object() const { return (*p_ & 0xf0) == 0x80 || *p_ == 0xde || *p_ == 0xdf; }
  bool is_array() const { return (*p_ & 0xf0) == 0x90 || *p_ == 0xdc || *p_ == 0xdd; }
  bool is_string() const { return (*p_ & 0xe0) == 0xa0 || (*p_ >= 0xd9 && *p_ <= 0xdb); }
  bool is_binary() const {
    return (*p_ >= 0xc4 && *p_ <= 0xc9) || (*p_ >= 0xd4 && *p_ <= 0xd8);
  }
  bool is_number_unsigned() const { return *p_ <= 0x7f || (*p_ >= 0xcc && *p_ <= 0xcf); }
  bool is_number_integer() const {
    return is_number_unsigned() || *p_ >= 0xe0 || (*p_ >= 0xd0 && *p_ <= 0xd3);
  }
  bool is_number() const { return is_number_integer() || *p_ == 0xca || *p_ == 0xcb; }

  // Elements of an array, members of an object; 0 for anything else.
  std::uint64_t size() const;
  // Numbers as nlohmann's get<T>() converts them. Precondition: is_number().
  double as_double() const;
  std::uint64_t as_unsigned() const;
  std::int64_t as_integer() const;
  // Payload of a string or binary value.
  std::string_view bytes() const;

  // First element of an array or first key of an object (size() > 0), and the value following
  // this one.
  MsgpackValue FirstElement() const;
  MsgpackValue Next() const { return MsgpackValue(End()); }
  // f(element) for every element of an array, in order.
  template <typename F>
  void ForEachElement(F&& f) const {
    const std::uint64_t n = size();
    MsgpackValue element = n ? FirstElement() : MsgpackValue();
    for (std::uint64_t i = 0; i < n; ++i) {
      f(element);
      if (i + 1 < n) element = element.Next();
    }
  }
  // The members of an object, collected in one pass for repeated lookups.
  class Members {
   public:
    // The member named key (the last one when repeated, as nlohmann keeps it), or an invalid
    // view (valid() false) when absent.
    MsgpackValue Find(std::string_view key) const;

   private:
    friend class MsgpackValue;
    std::vector<std::pair<std::string_view, MsgpackValue>> entries_;
  };
  // Precondition: is_object(). Throws MsgpackFormatError on a key that is not a string.
  Members MembersOf() const;
  bool valid() const { return p_ != nullptr; }
  const void* Raw() const { return p_; }

  // Compact JSON text of the value for error messages, cut to about max_chars.
  std::string Describe(std::size_t max_chars) const;

 private:
  // One past the end of this value, nested values included (iterative: nesting is bounded but
  // the scan keeps no recursion anyway).
  const unsigned char* End() const;
  // Byte count of a container's header (type byte and length).
  std::size_t HeaderSize() const;

  const unsigned char* p_ = nullptr;
};

}  // namespace lcv::mapping::internal
