// base/input_file.cc — vlt/input_file.h. The file is opened without blocking (O_NONBLOCK: opening
// a FIFO with no writer would wait forever) and judged by fstat on the open descriptor, so a file
// swapped for a FIFO or a device between a check and the read is still refused.
#include "vlt/input_file.h"

#include <cerrno>
#include <cstdio>
#include <cstring>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include "vlt/error.h"

namespace vlt {

namespace {

// An open descriptor, closed on every path out.
struct Descriptor {
  int fd = -1;
  ~Descriptor() {
    if (fd >= 0) ::close(fd);
  }
};

std::string KindOf(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory, not a file";
  if (S_ISFIFO(mode)) return "a FIFO (named pipe), not a regular file";
  if (S_ISCHR(mode) || S_ISBLK(mode)) return "a device, not a regular file";
  if (S_ISSOCK(mode)) return "a socket, not a regular file";
  return "not a regular file";
}

std::string Size(std::uint64_t bytes) {
  char text[48];
  std::snprintf(text, sizeof text, "%.3g GiB", static_cast<double>(bytes) / static_cast<double>(1ull << 30));
  return text;
}

// Opens `path` for reading and checks what it is: the problem, or "" with `out` open.
std::string Open(const std::string& path, Descriptor& out, std::uint64_t& size) {
  if (path.empty()) return "an empty file name";
  out.fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (out.fd < 0) return errno == ENOENT ? std::string("no such file") : std::string(std::strerror(errno));
  struct stat st {};
  if (::fstat(out.fd, &st) != 0) return std::strerror(errno);
  if (!S_ISREG(st.st_mode)) return KindOf(st.st_mode);
  size = static_cast<std::uint64_t>(st.st_size);
  if (size > kMaxInputFileBytes) return Size(size) + ": larger than vlt reads (" + Size(kMaxInputFileBytes) + ")";
  return "";
}

}  // namespace

std::string InputFileProblem(const std::string& path) {
  Descriptor file;
  std::uint64_t size = 0;
  return Open(path, file, size);
}

std::string ReadInputFile(const std::string& path, const std::string& label, const std::string& what) {
  Descriptor file;
  std::uint64_t size = 0;
  if (const std::string problem = Open(path, file, size); !problem.empty())
    throw InputError(label + ": " + what + ": " + problem);
  std::string text;
  text.reserve(static_cast<std::size_t>(size));
  char buffer[1 << 16];
  for (;;) {
    const ssize_t n = ::read(file.fd, buffer, sizeof buffer);
    if (n == 0) break;
    if (n < 0) {
      if (errno == EINTR) continue;
      throw InputError(label + ": " + what + ": " + std::strerror(errno));
    }
    // A regular file that grows while it is read (a log being written) stops at the cap too.
    if (text.size() + static_cast<std::size_t>(n) > kMaxInputFileBytes)
      throw InputError(label + ": " + what + ": grew past " + Size(kMaxInputFileBytes) + " while being read");
    text.append(buffer, static_cast<std::size_t>(n));
  }
  return text;
}

}  // namespace vlt
