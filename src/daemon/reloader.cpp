#include "ftid/daemon/reloader.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <exception>
#include <thread>

namespace ftid::daemon {

std::string regularFileProblem(const std::string& path) {
  // O_NONBLOCK: opening a FIFO (or a pipe through /proc/self/fd/N) returns at once instead of
  // waiting for a writer; fstat then tells what it is.
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_NOCTTY | O_CLOEXEC);
  if (fd < 0) return path + ": cannot open (" + std::strerror(errno) + ")";
  struct stat st {};
  const int rc = ::fstat(fd, &st);
  const int err = errno;
  ::close(fd);
  if (rc != 0) return path + ": cannot stat (" + std::strerror(err) + ")";
  if (S_ISREG(st.st_mode)) return {};
  const char* what = S_ISFIFO(st.st_mode)   ? "a FIFO"
                     : S_ISDIR(st.st_mode)  ? "a directory"
                     : S_ISCHR(st.st_mode)  ? "a character device"
                     : S_ISBLK(st.st_mode)  ? "a block device"
                     : S_ISSOCK(st.st_mode) ? "a socket"
                                            : "not a regular file";
  return path + ": is " + std::string(what) + ", not a regular file";
}

ParameterReloader::ParameterReloader(rt::OwnedSwapSlot<Compensation>* slot, CompensationFactory factory)
    : slot_(slot), factory_(std::move(factory)) {}

ReloadResult ParameterReloader::reload(const std::string& path,
                                       std::chrono::milliseconds apply_timeout) {
  ReloadResult result;
  std::unique_ptr<Compensation> fresh;
  try {
    fresh = factory_(path);
  } catch (const std::exception& e) {
    ++failed_;
    result.version = slot_->version();
    result.message = e.what();
    return result;
  }
  if (!fresh) {
    ++failed_;
    result.version = slot_->version();
    result.message = path + ": parameter file produced no model";
    return result;
  }
  ++succeeded_;
  return offer(std::move(fresh), apply_timeout);
}

ReloadResult ParameterReloader::offer(std::unique_ptr<Compensation> fresh,
                                      std::chrono::milliseconds apply_timeout) {
  ReloadResult result;
  const std::uint32_t before = slot_->version();
  slot_->post(std::move(fresh));
  result.ok = true;
  const auto deadline = std::chrono::steady_clock::now() + apply_timeout;
  while (slot_->hasPending() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
  result.applied = !slot_->hasPending() && slot_->version() > before;
  result.version = slot_->version();
  if (!result.applied) result.message = "loaded; waiting for the loop to take it into use";
  // The loop retires the previous object when it swaps; free it here (off the loop).
  slot_->collectRetired();
  return result;
}

}  // namespace ftid::daemon
