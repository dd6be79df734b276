// `lcv`: the one command-line program. Dispatches to the registered subcommands (apps/command.h)
// and is the only place that turns exceptions into messages and exit codes.

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <string>

#include <glog/logging.h>

#include "apps/command.h"
#include "slam/util/error.h"

namespace lcv::apps {
namespace {

std::vector<CommandInfo>& Registry() {
  static std::vector<CommandInfo> commands;
  return commands;
}

// Ceres logs through glog. Uninitialized, glog prints "WARNING: Logging before
// InitGoogleLogging()" before each of Ceres' warnings, and those warnings are recoverable events
// inside a solve (a Levenberg-Marquardt step whose linear solve failed is retried with more
// damping; 14 of ~6000 SLAM runs of the benchmarks had one), which the solver's own summary
// already accounts for. So: to stderr only (never glog's files in /tmp), errors and above,
// unless GLOG_minloglevel / GLOG_v in the environment ask for more.
void InitSolverLogging(const char* argv0) {
  FLAGS_logtostderr = true;
  if (std::getenv("GLOG_minloglevel") == nullptr) FLAGS_minloglevel = google::GLOG_ERROR;
  google::InitGoogleLogging(argv0);
}

void PrintUsage(std::ostream& out) {
  out << "usage: lcv <command> [<subcommand>] [options]   (lcv <command> --help for details)\n\n"
         "LC-VSLAM: privacy-preserving visual SLAM in line clouds, map processing and audits.\n\n"
         "commands:\n";
  size_t width = 0;
  for (const auto& c : Commands()) width = std::max(width, c.name.size());
  for (const auto& c : Commands()) {
    out << "  " << c.name << std::string(width + 2 - c.name.size(), ' ') << c.summary << "\n";
  }
}

}  // namespace

const std::vector<CommandInfo>& Commands() {
  auto& commands = Registry();
  std::sort(commands.begin(), commands.end(),
            [](const CommandInfo& a, const CommandInfo& b) { return a.name < b.name; });
  return commands;
}

internal::CommandRegistrar::CommandRegistrar(const char* name, const char* summary,
                                             CommandHandler handler) {
  Registry().push_back({name, summary, handler});
}

}  // namespace lcv::apps

int main(int argc, char** argv) {
  using namespace lcv::apps;
  InitSolverLogging(argv[0]);
  if (argc < 2) {
    PrintUsage(std::cerr);
    return kExitUsage;
  }
  const std::string first = argv[1];
  if (first == "help" || first == "-h" || first == "--help") {
    PrintUsage(std::cout);
    return kExitOk;
  }
  if (first == "--version") {
    std::cout << "lcv 0.1.0\n";
    return kExitOk;
  }
  // Two-word commands ("map convert") first, then one-word ones.
  const CommandInfo* command = nullptr;
  int consumed = 1;
  if (argc >= 3) {
    const std::string two = first + " " + argv[2];
    for (const auto& c : Commands()) {
      if (c.name == two) {
        command = &c;
        consumed = 2;
      }
    }
  }
  if (!command) {
    for (const auto& c : Commands()) {
      if (c.name == first) command = &c;
    }
  }
  if (!command) {
    // A group name alone ("lcv map") lists its subcommands.
    bool is_group = false;
    for (const auto& c : Commands()) is_group |= c.name.rfind(first + " ", 0) == 0;
    if (is_group) {
      std::ostream& out = (argc >= 3 && std::strcmp(argv[2], "--help") && std::strcmp(argv[2], "-h"))
                              ? std::cerr : std::cout;
      if (&out == &std::cerr) out << "lcv: unknown subcommand '" << first << " " << argv[2] << "'\n";
      out << "subcommands of '" << first << "':\n";
      for (const auto& c : Commands()) {
        if (c.name.rfind(first + " ", 0) == 0) out << "  " << c.name << "  " << c.summary << "\n";
      }
      return &out == &std::cerr ? kExitUsage : kExitOk;
    }
    std::cerr << "lcv: unknown command '" << first << "' (see 'lcv help')\n";
    return kExitUsage;
  }
  // The handler sees argv[0] = the command name and the remaining arguments.
  std::vector<char*> args;
  std::string name = command->name;
  args.push_back(name.data());
  for (int i = 1 + consumed; i < argc; ++i) args.push_back(argv[i]);
  args.push_back(nullptr);
  try {
    return command->handler(static_cast<int>(args.size()) - 1, args.data());
  } catch (const UsageError& e) {
    std::cerr << "lcv " << name << ": " << e.what() << "\n";
    return kExitUsage;
  } catch (const lcv::InputError& e) {
    std::cerr << "lcv " << name << ": error: " << e.what() << "\n";
    return kExitFailure;
  } catch (const std::exception& e) {
    std::cerr << "lcv " << name << ": internal error: " << e.what() << "\n";
    return kExitFailure;
  }
}
