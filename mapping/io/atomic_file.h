#pragma once
// Safe file I/O for every file the project reads from or writes to the user's disk.
//
// Writing: the bytes go to "<path>.tmp-<pid>" first, created with O_EXCL | O_NOFOLLOW (a file or
// symlink planted at that name is never written through), fsync'ed, renamed into place, and the
// folder is fsync'ed, so a crash or kill -9 leaves either the old or the complete new file.
// After a successful write, "<name>.tmp-<pid>" files next to the target whose process is gone
// (left by a killed writer) are removed.
//
// Reading: bounded. Every read streams in chunks and stops at a size limit; a regular file larger
// than the limit is refused before its first byte is read; text readers refuse a NUL byte at the
// first chunk that has one, so /dev/zero or a huge binary file fails in milliseconds instead of
// filling memory. Folders are named as such.
//
// Failure: lcv::InputError whose message starts with the path. Thread safety: the functions keep
// no state; concurrent writes of the same target from one process are not supported.

#include <cstddef>
#include <functional>
#include <iosfwd>
#include <string>
#include <string_view>

namespace lcv::mapping {

// Largest input file read whole: maps (the largest inputs) and everything else.
inline constexpr std::size_t kMaxInputFileBytes = std::size_t{4} << 30;  // 4 GiB
// Largest text input (camera files, trajectories, dataset lists, COLMAP models, rules).
inline constexpr std::size_t kMaxTextFileBytes = std::size_t{1} << 30;  // 1 GiB

// Writes bytes to path atomically. Throws lcv::InputError naming the path on failure (missing
// folder, no permission, disk full, a folder at path).
void WriteFileAtomically(const std::string& path, const std::string& bytes);

// Calls write(stream) on a temporary file next to path, then renames it into place. The temporary
// is removed if write throws or the stream fails. An existing target that is a device or FIFO
// (/dev/null, /dev/stdout) is written in place instead, never replaced.
void WriteFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& write);

// Checks that path can be written later, before a command does its work: not a folder, its folder
// exists and is a writable folder. Throws lcv::InputError naming the path and the problem.
// flag names the option in the message (e.g. "--map-out"); may be empty.
void CheckOutputPath(const std::string& path, const std::string& flag = "");

// Whole file as bytes, at most max_bytes. Throws lcv::InputError naming the path when it cannot be
// read, is a folder, or is larger than max_bytes.
std::string ReadFileBytes(const std::string& path, std::size_t max_bytes = kMaxInputFileBytes);

// ReadFileBytes that also refuses a NUL byte (binary data is never a text input), checked chunk by
// chunk while reading.
std::string ReadTextFile(const std::string& path, std::size_t max_bytes = kMaxTextFileBytes);

// ReadFileBytes whose first chunk (up to 64 KiB, or the whole file when smaller) is shown to
// check_head before the rest is read; check_head throws to refuse the file (e.g. a wrong magic)
// without reading a 3 GB file whole.
std::string ReadFileBytesChecked(const std::string& path, std::size_t max_bytes,
                                 const std::function<void(std::string_view head)>& check_head);

// Removes "<file name of path>.tmp-<pid>" files in path's folder whose process no longer exists.
// Returns how many were removed. Called by WriteFileAtomically after each successful write.
int RemoveStaleTemporaries(const std::string& path);

}  // namespace lcv::mapping
