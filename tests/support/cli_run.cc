#include "tests/support/cli_run.h"

#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

namespace lcv::test {
namespace {

std::string Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace

CliResult RunLcv(const std::string& arguments, const std::string& scratch_dir) {
  const std::string out_path = scratch_dir + "/out.txt";
  const std::string err_path = scratch_dir + "/err.txt";
  const std::string command =
      std::string(LCV_BINARY) + " " + arguments + " >" + out_path + " 2>" + err_path;
  const int status = std::system(command.c_str());
  CliResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  result.out = Slurp(out_path);
  result.err = Slurp(err_path);
  return result;
}

}  // namespace lcv::test
