#include "mapping/io/atomic_file.h"

#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <ostream>
#include <streambuf>
#include <vector>

#include "slam/util/error.h"

namespace lcv::mapping {

namespace {

std::string ErrnoText(int error) { return std::strerror(error); }

// The folder of path ("." for a bare file name) and the file name.
void SplitPath(const std::string& path, std::string* folder, std::string* name) {
  const std::size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) {
    *folder = ".";
    *name = path;
  } else {
    *folder = slash == 0 ? "/" : path.substr(0, slash);
    *name = path.substr(slash + 1);
  }
}

// Owns a file descriptor; closes it on scope exit unless released.
class Fd {
 public:
  explicit Fd(int fd) : fd_(fd) {}
  ~Fd() {
    if (fd_ >= 0) ::close(fd_);
  }
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  int get() const { return fd_; }
  // close(2) with its result (a failed close can be a failed write on NFS).
  int Close() {
    const int result = ::close(fd_);
    fd_ = -1;
    return result;
  }

 private:
  int fd_;
};

// std::streambuf over a file descriptor: the writers keep their std::ostream interface while the
// file is created with open(2) flags that std::ofstream cannot pass. A failed write(2) makes the
// stream bad and keeps errno in error().
class FdStreamBuf : public std::streambuf {
 public:
  explicit FdStreamBuf(int fd) : fd_(fd), buffer_(1 << 16) {
    setp(buffer_.data(), buffer_.data() + buffer_.size());
  }
  int error() const { return error_; }

 protected:
  int_type overflow(int_type c) override {
    if (!Drain()) return traits_type::eof();
    if (!traits_type::eq_int_type(c, traits_type::eof())) {
      *pptr() = traits_type::to_char_type(c);
      pbump(1);
    }
    return traits_type::not_eof(c);
  }
  int sync() override { return Drain() ? 0 : -1; }

 private:
  bool Drain() {
    const char* data = pbase();
    std::size_t left = static_cast<std::size_t>(pptr() - pbase());
    while (left > 0) {
      const ssize_t written = ::write(fd_, data, left);
      if (written < 0) {
        if (errno == EINTR) continue;
        error_ = errno;
        return false;
      }
      data += written;
      left -= static_cast<std::size_t>(written);
    }
    setp(buffer_.data(), buffer_.data() + buffer_.size());
    return true;
  }

  int fd_;
  std::vector<char> buffer_;
  int error_ = 0;
};

// fsync of a folder makes a rename in it durable. Best effort: the new file is already in place
// and complete, and some file systems refuse to sync a folder (EINVAL).
void SyncFolder(const std::string& folder) {
  const int fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  Fd owner(fd);
  ::fsync(fd);
}

void WriteInPlace(const std::string& path, const std::function<void(std::ostream&)>& write) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw InputError(path, "cannot write: " + ErrnoText(errno));
  write(out);
  out.flush();
  if (!out) throw InputError(path, "write failed");
}

// Reads path in chunks: on_chunk(data, size, offset) may throw to stop; stops with an error past
// max_bytes. head_bytes > 0 delays the first call until that many bytes (or the whole file) are
// in, for checks of a file's start.
std::string ReadBounded(const std::string& path, std::size_t max_bytes, std::size_t head_bytes,
                        const std::function<void(std::string_view head)>& check_head,
                        bool text) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    throw InputError(path, "cannot open: " + ErrnoText(errno));
  }
  Fd owner(fd);
  struct stat info;
  if (::fstat(fd, &info) != 0) throw InputError(path, "cannot stat: " + ErrnoText(errno));
  if (S_ISDIR(info.st_mode)) throw InputError(path, "is a folder, not a file");
  const bool regular = S_ISREG(info.st_mode);
  if (regular && static_cast<std::uint64_t>(info.st_size) > max_bytes) {
    throw InputError(path, "file of " + std::to_string(info.st_size) +
                               " bytes is larger than the limit of " + std::to_string(max_bytes) +
                               " bytes for this kind of file");
  }
  std::string bytes;
  // Reserved only once the head is accepted: a huge file refused by its first bytes costs nothing.
  auto reserve = [&] {
    if (regular) bytes.reserve(static_cast<std::size_t>(info.st_size) + 1);
  };
  constexpr std::size_t kChunk = std::size_t{1} << 20;
  std::size_t checked_for_nul = 0;
  bool head_checked = !check_head;
  if (head_checked) reserve();
  for (;;) {
    const std::size_t old_size = bytes.size();
    const std::size_t want = std::min(kChunk, max_bytes + 1 - old_size);
    bytes.resize(old_size + want);
    const ssize_t got = ::read(fd, &bytes[old_size], want);
    if (got < 0) {
      if (errno == EINTR) {
        bytes.resize(old_size);
        continue;
      }
      throw InputError(path, "read error: " + ErrnoText(errno));
    }
    bytes.resize(old_size + static_cast<std::size_t>(got));
    const bool end = got == 0;
    if (text) {
      const void* nul = std::memchr(bytes.data() + checked_for_nul, '\0',
                                    bytes.size() - checked_for_nul);
      if (nul) {
        const std::size_t at = static_cast<const char*>(nul) - bytes.data();
        throw InputError(path, "binary data (a NUL byte at byte " + std::to_string(at) +
                                   "), not a text file");
      }
      checked_for_nul = bytes.size();
    }
    if (!head_checked && (end || bytes.size() >= head_bytes)) {
      head_checked = true;
      check_head(std::string_view(bytes.data(), std::min(bytes.size(), head_bytes)));
      reserve();
    }
    if (bytes.size() > max_bytes) {
      throw InputError(path, "more than the limit of " + std::to_string(max_bytes) +
                                 " bytes for this kind of file");
    }
    if (end) break;
  }
  bytes.shrink_to_fit();
  return bytes;
}

bool AllDigits(const std::string& s) {
  return !s.empty() && s.size() <= 10 &&
         std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

}  // namespace

void WriteFileAtomically(const std::string& path, const std::function<void(std::ostream&)>& write) {
  struct stat info;
  if (::stat(path.c_str(), &info) == 0) {
    if (S_ISDIR(info.st_mode)) throw InputError(path, "is a folder, cannot write a file there");
    // A device or FIFO (/dev/null, /dev/stdout): renaming a temporary file over it would replace
    // the node, so it is written in place.
    if (!S_ISREG(info.st_mode)) return WriteInPlace(path, write);
  }
  std::string folder, name;
  SplitPath(path, &folder, &name);
  const std::string tmp = path + ".tmp-" + std::to_string(::getpid());
  constexpr int kFlags = O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC;
  int fd = ::open(tmp.c_str(), kFlags, 0666);
  if (fd < 0 && errno == EEXIST) {
    // A name with our own pid is a leftover of an earlier process that had it, or planted. Remove
    // the name itself (never what a symlink there points to) and create it afresh.
    ::unlink(tmp.c_str());
    fd = ::open(tmp.c_str(), kFlags, 0666);
  }
  if (fd < 0) {
    const int error = errno;
    struct stat folder_info;
    if (::stat(folder.c_str(), &folder_info) != 0) {
      throw InputError(path, "cannot write: its folder " + folder + " does not exist");
    }
    throw InputError(path, "cannot write (temporary file " + tmp + "): " + ErrnoText(error));
  }
  Fd file(fd);
  auto fail = [&](const std::string& what) {
    ::unlink(tmp.c_str());
    throw InputError(path, what);
  };
  {
    FdStreamBuf buffer(fd);
    std::ostream out(&buffer);
    try {
      write(out);
    } catch (...) {
      ::unlink(tmp.c_str());
      throw;
    }
    out.flush();
    if (!out) {
      fail("write failed: " + (buffer.error() ? ErrnoText(buffer.error()) : "stream error"));
    }
  }
  if (::fsync(fd) != 0) fail("cannot sync to disk: " + ErrnoText(errno));
  if (file.Close() != 0) fail("write failed on close: " + ErrnoText(errno));
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    fail("cannot rename temporary file into place: " + ErrnoText(errno));
  }
  SyncFolder(folder);
  RemoveStaleTemporaries(path);
}

void WriteFileAtomically(const std::string& path, const std::string& bytes) {
  WriteFileAtomically(path, [&](std::ostream& out) { out.write(bytes.data(), bytes.size()); });
}

int RemoveStaleTemporaries(const std::string& path) {
  std::string folder, name;
  SplitPath(path, &folder, &name);
  const std::string prefix = name + ".tmp-";
  DIR* dir = ::opendir(folder.c_str());
  if (!dir) return 0;
  int removed = 0;
  while (const dirent* entry = ::readdir(dir)) {
    const std::string entry_name = entry->d_name;
    if (entry_name.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string pid_text = entry_name.substr(prefix.size());
    if (!AllDigits(pid_text)) continue;
    const long long pid = std::stoll(pid_text);
    if (pid <= 0 || pid == ::getpid() || pid > 0x7fffffff) continue;
    // kill(pid, 0) fails with ESRCH only when no such process exists (EPERM: alive, not ours).
    if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;
    if (::unlink((folder + "/" + entry_name).c_str()) == 0) ++removed;
  }
  ::closedir(dir);
  return removed;
}

void CheckOutputPath(const std::string& path, const std::string& flag) {
  const std::string who = flag.empty() ? path : path + " (" + flag + ")";
  if (path.empty()) throw InputError(flag.empty() ? "output" : flag, "empty output path");
  struct stat info;
  if (::stat(path.c_str(), &info) == 0) {
    if (S_ISDIR(info.st_mode)) throw InputError(who, "is a folder, expected a file name");
    if (!S_ISREG(info.st_mode)) return;  // a device such as /dev/null, written in place
  }
  std::string folder, name;
  SplitPath(path, &folder, &name);
  if (name.empty()) throw InputError(who, "names a folder, expected a file name");
  if (::stat(folder.c_str(), &info) != 0) {
    throw InputError(who, "cannot be written: its folder " + folder + " does not exist");
  }
  if (!S_ISDIR(info.st_mode)) {
    throw InputError(who, "cannot be written: " + folder + " is not a folder");
  }
  if (::access(folder.c_str(), W_OK | X_OK) != 0) {
    throw InputError(who, "cannot be written: no permission to create files in " + folder);
  }
}

std::string ReadFileBytes(const std::string& path, std::size_t max_bytes) {
  return ReadBounded(path, max_bytes, 0, nullptr, false);
}

std::string ReadTextFile(const std::string& path, std::size_t max_bytes) {
  return ReadBounded(path, max_bytes, 0, nullptr, true);
}

std::string ReadFileBytesChecked(const std::string& path, std::size_t max_bytes,
                                 const std::function<void(std::string_view head)>& check_head) {
  return ReadBounded(path, max_bytes, std::size_t{1} << 16, check_head, false);
}

}  // namespace lcv::mapping
