#include "mapping/io/shared_library.h"

#include <dlfcn.h>

#include <filesystem>
#include <system_error>

#include "slam/util/error.h"

namespace lcv::mapping {

SharedLibrary SharedLibrary::Open(const std::vector<std::string>& candidates,
                                  const std::string& purpose) {
  LCV_CHECK(!candidates.empty()) << purpose;
  std::string reasons;
  for (const std::string& candidate : candidates) {
    // RTLD_LOCAL: the library's symbols do not leak into later lookups of other libraries.
    void* handle = dlopen(candidate.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (handle) return SharedLibrary(handle, candidate);
    const char* error = dlerror();
    reasons += "; " + candidate + ": " + (error ? error : "cannot be loaded");
  }
  throw InputError(candidates.front(), "cannot load the library needed " + purpose +
                                           " (tried" + reasons.substr(1) + ")");
}

void* SharedLibrary::Symbol(const char* name) const {
  dlerror();  // clear a stale error
  void* address = dlsym(handle_, name);
  if (!address) {
    const char* error = dlerror();
    throw InputError(path_, std::string("no symbol ") + name + (error ? std::string(": ") + error : ""));
  }
  return address;
}

std::string ExecutableDir() {
  std::error_code error;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", error);
  if (error) return "";
  return exe.parent_path().string();
}

}  // namespace lcv::mapping
