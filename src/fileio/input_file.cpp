// Reading untrusted input files (include/ftid/fileio/input_file.hpp).
#include "ftid/fileio/input_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
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

namespace {

/// Opens `path` for reading after the checks of readInputFile; returns the descriptor and sets
/// `size`. Throws FileError (the descriptor closed).
int openChecked(const std::string& path, const std::string& what, std::size_t max_bytes, std::size_t& size) {
  if (path.empty()) throw FileError("no " + what + " given (empty path)");
  // stat first so a device node is never even opened; fstat after open closes the race.
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    throw FileError(path + ": cannot open the " + what + ": " + std::strerror(errno));
  }
  if (!S_ISREG(st.st_mode)) notRegular(path, what, st.st_mode);
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) throw FileError(path + ": cannot open the " + what + ": " + std::strerror(errno));
  try {
    if (::fstat(fd, &st) != 0) throw FileError(path + ": cannot stat the " + what + ": " + std::strerror(errno));
    if (!S_ISREG(st.st_mode)) notRegular(path, what, st.st_mode);
    size = static_cast<std::size_t>(st.st_size);
    if (size > max_bytes) {
      throw FileError(path + ": the " + what + " is too large (" + std::to_string(size) + " bytes; at most " +
                      mib(max_bytes) + ")");
    }
  } catch (...) {
    ::close(fd);
    throw;
  }
  return fd;
}

/// One read(2) of up to `n` bytes, retried on EINTR; 0 at the end.
std::size_t readSome(int fd, char* buf, std::size_t n, const std::string& path, const std::string& what) {
  while (true) {
    const ssize_t got = ::read(fd, buf, n);
    if (got >= 0) return static_cast<std::size_t>(got);
    if (errno != EINTR) throw FileError(path + ": cannot read the " + what + ": " + std::strerror(errno));
  }
}

}  // namespace

std::string readInputFile(const std::string& path, const std::string& what, std::size_t max_bytes) {
  InputFileReader reader(path, what, max_bytes);
  std::string text(reader.size(), '\0');
  std::size_t done = 0;
  while (true) {
    if (done == text.size()) text.resize(std::min(max_bytes + 1, text.size() + 65536));  // the file may have grown
    const std::size_t n = reader.read(&text[done], text.size() - done);
    if (n == 0) break;
    done += n;
  }
  text.resize(done);
  return text;
}

InputFileReader::InputFileReader(const std::string& path, const std::string& what, std::size_t max_bytes)
    : path_(path), what_(what), max_bytes_(max_bytes) {
  fd_ = openChecked(path, what, max_bytes, size_);
}

InputFileReader::~InputFileReader() {
  if (fd_ >= 0) ::close(fd_);
}

std::size_t InputFileReader::read(char* buf, std::size_t n) {
  // One byte beyond the limit is asked for, so a file that grew past it is seen.
  const std::size_t room = max_bytes_ + 1 - done_;
  const std::size_t got = readSome(fd_, buf, std::min(n, room), path_, what_);
  done_ += got;
  if (done_ > max_bytes_) {
    throw FileError(path_ + ": the " + what_ + " is too large (at most " + mib(max_bytes_) + ")");
  }
  return got;
}

}  // namespace ftid
