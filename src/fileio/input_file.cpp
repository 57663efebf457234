// Reading untrusted input files (include/ftid/fileio/input_file.hpp).
#include "ftid/fileio/input_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace ftid {

namespace {

[[noreturn]] void notRegular(const std::string& path, const std::string& what, mode_t mode) {
  throw FileError(path + ": cannot read the " + what + ": it is a " + fileKindName(mode) +
                  ", not a regular file");
}

std::string mib(std::size_t bytes) { return std::to_string(bytes >> 20) + " MiB"; }

}  // namespace

std::string readInputFile(const std::string& path, const std::string& what, std::size_t max_bytes) {
  if (path.empty()) throw FileError("no " + what + " given (empty path)");
  // stat first so a device node is never even opened; fstat after open closes the race.
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    throw FileError(path + ": cannot open the " + what + ": " + std::strerror(errno));
  }
  if (!S_ISREG(st.st_mode)) notRegular(path, what, st.st_mode);
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) throw FileError(path + ": cannot open the " + what + ": " + std::strerror(errno));
  std::string text;
  try {
    if (::fstat(fd, &st) != 0) throw FileError(path + ": cannot stat the " + what + ": " + std::strerror(errno));
    if (!S_ISREG(st.st_mode)) notRegular(path, what, st.st_mode);
    const auto size = static_cast<std::size_t>(st.st_size);
    if (size > max_bytes) {
      throw FileError(path + ": the " + what + " is too large (" + std::to_string(size) + " bytes; at most " +
                      mib(max_bytes) + ")");
    }
    text.resize(size);
    std::size_t done = 0;
    while (true) {
      if (done == text.size()) {
        if (text.size() >= max_bytes + 1) break;
        text.resize(std::min(max_bytes + 1, text.size() + 65536));  // the file may have grown
      }
      const ssize_t n = ::read(fd, &text[done], text.size() - done);
      if (n < 0) {
        if (errno == EINTR) continue;
        throw FileError(path + ": cannot read the " + what + ": " + std::strerror(errno));
      }
      if (n == 0) break;
      done += static_cast<std::size_t>(n);
    }
    text.resize(done);
    if (done > max_bytes) {
      throw FileError(path + ": the " + what + " is too large (at most " + mib(max_bytes) + ")");
    }
  } catch (...) {
    ::close(fd);
    throw;
  }
  ::close(fd);
  return text;
}

}  // namespace ftid
