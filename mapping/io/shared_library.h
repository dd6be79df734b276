#pragma once
// Libraries opened at run time (dlopen) instead of linked: OpenCV's image and video codecs (the
// lcv_media plugin, mapping/io/media.h) and OSMesa (render/offscreen_context.cc). Linked, they
// and what they pull in (GDAL, GStreamer, FFmpeg, LLVM: ~250 libraries, ~110 MB of relocated
// pages) would be loaded by every command, including the ones that only read a map file
// (README "Hardening"). Opened here, only the commands that decode images, write videos or
// render pay for them.
//
// A library, once opened, stays loaded until the process exits (never dlclose: OpenCV and Mesa
// keep static state and threads that must not outlive their code).
//
// Thread safety: Open and Symbol may be called from any thread (dlopen is thread-safe).
// Failure: lcv::InputError whose message names the file that could not be loaded and why
// (a missing or broken installation is a problem of the input, not a bug of the program).

#include <string>
#include <vector>

namespace lcv::mapping {

class SharedLibrary {
 public:
  // Opens the first candidate that loads. A candidate with a '/' is a file path; one without is
  // a soname looked up by the dynamic loader (e.g. "libOSMesa.so.8"). `purpose` says what the
  // library is needed for, for the error message. Throws lcv::InputError naming every candidate
  // tried with the loader's reason.
  static SharedLibrary Open(const std::vector<std::string>& candidates, const std::string& purpose);

  // The address of an exported symbol. Throws lcv::InputError naming the library and the symbol.
  void* Symbol(const char* name) const;

  // The candidate that was opened.
  const std::string& path() const { return path_; }

 private:
  SharedLibrary(void* handle, std::string path) : handle_(handle), path_(std::move(path)) {}
  void* handle_;
  std::string path_;
};

// The folder of the running executable (from /proc/self/exe), e.g. "/home/u/lcvslam/build" for
// build/lcv; empty when it cannot be read. Plugins are looked up there first, so that a build
// folder or an installed tree works from any working directory.
std::string ExecutableDir();

}  // namespace lcv::mapping
