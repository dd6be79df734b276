#pragma once
// Loss-free output: every file the project writes goes to "<path>.tmp-<pid>" first and is renamed
// into place, so a crash or a failed write never leaves a truncated file where a good one was.

#include <functional>
#include <iosfwd>
#include <string>

namespace lcv::mapping {

// Writes bytes to path atomically. Throws lcv::InputError naming the path on failure (missing
// folder, no permission, disk full).
void WriteFileAtomically(const std::string& path, const std::string& bytes);

// Calls write(stream) on a temporary file next to path, then renames it into place. The temporary
// is removed if write throws or the stream fails.
void WriteFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& write);

// Whole file as bytes. Throws lcv::InputError naming the path when it cannot be read.
std::string ReadFileBytes(const std::string& path);

}  // namespace lcv::mapping
