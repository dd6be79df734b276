#pragma once
// A small, strict command-line parser for the subcommands: --flag VALUE, --flag=VALUE, boolean
// --switch, positional arguments, -h/--help. Unknown flags and missing values are UsageErrors
// naming the flag. Each flag is declared with its help text and default so that --help prints
// every option (STYLE.md 7).

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "apps/command.h"

namespace lcv::apps {

class ArgParser {
 public:
  // usage: "lcv map convert --to-lines IN OUT [--seed N]"; description: a few lines of prose;
  // example: a full command line.
  ArgParser(std::string usage, std::string description, std::string example = "");

  // Declare options before Parse(). value_name is shown in help ("N", "FILE"); an empty
  // default_value means "no default".
  void AddOption(const std::string& flag, const std::string& value_name, const std::string& help,
                 const std::string& default_value = "");
  void AddSwitch(const std::string& flag, const std::string& help);
  // Positional arguments, in order; optional ones must come last.
  void AddPositional(const std::string& name, const std::string& help, bool required = true);
  // The last positional may take one or more values ("UPLOAD..."): PositionalList(name).
  void AddPositionalList(const std::string& name, const std::string& help);

  // Returns false when --help was given (help already printed to stdout: return kExitOk).
  // Throws UsageError on a malformed command line.
  bool Parse(int argc, char** argv);

  bool Has(const std::string& flag) const;  // given on the command line (or a switch set)
  std::string Get(const std::string& flag) const;  // value or default; UsageError if neither
  std::optional<std::string> GetOptional(const std::string& flag) const;
  // Every value of an option that may be repeated (--images A --images B), in order.
  std::vector<std::string> GetAll(const std::string& flag) const;
  int GetInt(const std::string& flag) const;
  double GetDouble(const std::string& flag) const;
  std::uint64_t GetSeed(const std::string& flag = "--seed") const;
  // "640x360" -> (640, 360); UsageError naming the flag unless min <= W, H <= max.
  std::pair<int, int> GetSize(const std::string& flag, int min = 16, int max = 8192) const;
  std::string Positional(const std::string& name) const;
  std::optional<std::string> PositionalOptional(const std::string& name) const;
  std::vector<std::string> PositionalList(const std::string& name) const;

  // Checks, before any work, that every named output that was given (option flags such as
  // "--map-out", or positional names such as "OUT") can be written: not a folder, in an existing
  // writable folder (mapping::CheckOutputPath). Throws lcv::InputError naming the path and flag.
  void CheckOutputs(const std::vector<std::string>& names) const;

  std::string Help() const;

 private:
  struct Option {
    std::string value_name;  // empty for switches
    std::string help;
    std::string default_value;
  };
  struct PositionalSpec {
    std::string name, help;
    bool required;
  };
  std::string usage_, description_, example_;
  std::vector<std::string> option_order_;
  std::map<std::string, Option> options_;
  std::vector<PositionalSpec> positional_specs_;
  std::map<std::string, std::vector<std::string>> values_;
  std::map<std::string, std::string> positionals_;
  bool last_positional_is_list_ = false;
  std::vector<std::string> positional_list_;
};

}  // namespace lcv::apps
