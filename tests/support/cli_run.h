#pragma once
// Runs the built `lcv` (LCV_BINARY) as a user would, for the command-line tests.

#include <string>

namespace lcv::test {

struct CliResult {
  int exit_code = -1;  // -1 when the process did not exit normally
  std::string out;     // stdout
  std::string err;     // stderr
};

// Runs `lcv <arguments>` through the shell; stdout and stderr go through files in scratch_dir
// (which must exist).
CliResult RunLcv(const std::string& arguments, const std::string& scratch_dir);

}  // namespace lcv::test
