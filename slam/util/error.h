#pragma once
// Error conventions of the whole project (STYLE.md 4).
//
// - A broken precondition inside the code is a bug: LCV_CHECK(cond) << "context" throws
//   std::logic_error with file:line and the condition text.
// - Bad user input (a file, a config field, a flag) is not a bug: it is reported by throwing
//   lcv::InputError whose message names the file, the field and the value, e.g.
//   "a.lcmap: /lines/17/direction: norm 0". Only mapping/io and apps validate input, and only
//   apps catch.
// - Expected outcomes (no solution, tracking lost) are values, never exceptions.

#include <sstream>
#include <stdexcept>
#include <string>

namespace lcv {

// Bad input from outside the program: a file, a config field, a command-line flag.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& message) : std::runtime_error(message) {}
  // "<path>: <what>", the form every reader uses.
  InputError(const std::string& path, const std::string& what)
      : std::runtime_error(path + ": " + what) {}
};

namespace internal {

// Collects the streamed context of a failed LCV_CHECK and throws when the statement ends.
class CheckFailure {
 public:
  CheckFailure(const char* file, int line, const char* condition) {
    stream_ << file << ":" << line << ": check failed: " << condition;
  }
  template <typename T>
  CheckFailure& operator<<(const T& value) {
    if (!has_context_) {
      stream_ << ": ";
      has_context_ = true;
    }
    stream_ << value;
    return *this;
  }
  ~CheckFailure() noexcept(false) { throw std::logic_error(stream_.str()); }

 private:
  std::ostringstream stream_;
  bool has_context_ = false;
};

}  // namespace internal
}  // namespace lcv

// Throws std::logic_error("file:line: check failed: cond: <streamed context>") when !cond.
#define LCV_CHECK(condition) \
  if (condition) {           \
  } else                     \
    ::lcv::internal::CheckFailure(__FILE__, __LINE__, #condition)
