#pragma once
// Subcommand registry of the `lcv` program (STYLE.md 7).
//
// Each apps/cmd_<name>.cc defines `int Run<Name>(int argc, char** argv)` and registers it with
//   LCV_REGISTER_COMMAND("map convert", "point map -> published line cloud", RunMapConvert);
// A command name has one or two words ("demo", "map convert"). argv[0] of the handler is the
// full command name; the handler parses the rest.
//
// Exit codes: 0 ok, 1 runtime failure (bad input file, ...), 2 usage error, 3 check failed
// (audit leak, eval threshold). Handlers may throw lcv::InputError / UsageError; main() catches
// them, prints "lcv <command>: <message>" on stderr and returns 1 / 2.

#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace lcv::apps {

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;
inline constexpr int kExitUsage = 2;
inline constexpr int kExitCheckFailed = 3;

// A command-line mistake: unknown flag, missing argument, bad value. Exit code 2.
class UsageError : public std::runtime_error {
 public:
  explicit UsageError(const std::string& m) : std::runtime_error(m) {}
};

using CommandHandler = int (*)(int argc, char** argv);

struct CommandInfo {
  std::string name;     // "map convert"
  std::string summary;  // one line for `lcv help`
  CommandHandler handler;
};

// All registered commands, sorted by name.
const std::vector<CommandInfo>& Commands();

namespace internal {
struct CommandRegistrar {
  CommandRegistrar(const char* name, const char* summary, CommandHandler handler);
};
}  // namespace internal

}  // namespace lcv::apps

#define LCV_INTERNAL_CONCAT2(a, b) a##b
#define LCV_INTERNAL_CONCAT(a, b) LCV_INTERNAL_CONCAT2(a, b)
#define LCV_REGISTER_COMMAND(name, summary, handler)                                     \
  static ::lcv::apps::internal::CommandRegistrar LCV_INTERNAL_CONCAT(lcv_command_, __LINE__)( \
      name, summary, handler)
