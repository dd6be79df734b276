// `lcv version`: version and the library versions it was built with.
#include <Eigen/Core>
#include <iostream>

#include "apps/args.h"
#include "apps/command.h"

namespace lcv::apps {
namespace {

int RunVersion(int argc, char** argv) {
  ArgParser args("lcv version", "Prints the version of lcv and of the libraries it was built with.");
  if (!args.Parse(argc, argv)) return kExitOk;
  std::cout << "lcv 0.1.0 (Eigen " << EIGEN_WORLD_VERSION << "." << EIGEN_MAJOR_VERSION << "."
            << EIGEN_MINOR_VERSION << ")\n";
  return kExitOk;
}

}  // namespace
LCV_REGISTER_COMMAND("version", "print version information", RunVersion);
}  // namespace lcv::apps
