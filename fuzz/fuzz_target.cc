// libFuzzer entry point for one reader (LCV_FUZZ_READER, see fuzz/CMakeLists.txt): every input
// must be accepted or refused with lcv::InputError; any other exception escapes and aborts, which
// libFuzzer reports as a crash with the input that caused it.
#include <unistd.h>

#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <cstdint>
#include <filesystem>
#include <string>

#include "fuzz/fuzz_readers.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string scratch = [] {
    const std::string dir = (std::filesystem::temp_directory_path() /
                             ("lcv_fuzz_" + std::to_string(::getpid())))
                                .string();
    lcv::fuzz::PrepareScratch(dir);
    return dir;
  }();
  try {
    lcv::fuzz::ReadOne(LCV_FUZZ_READER, std::string(reinterpret_cast<const char*>(data), size),
                       scratch);
  } catch (const lcv::InputError& e) {
    // A refused input, the expected outcome for most mutations, must name the input.
    if (!lcv::fuzz::NamesInput(e.what(), scratch)) {
      std::fprintf(stderr, "error names no input: %s\n", e.what());
      std::abort();
    }
  }
  return 0;
}
