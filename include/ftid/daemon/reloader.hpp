#pragma once
// Parameter reload without missing a cycle: the new Compensation is built (parameter file read,
// validated, model composed, workspace allocated) on the calling non-RT thread, then offered to
// the loop through an OwnedSwapSlot; the loop swaps pointers at the start of its next cycle and
// the replaced object is freed here, off the loop.
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "ftid/daemon/seams.hpp"
#include "ftid/rt/swap_slot.hpp"

namespace ftid::daemon {

/// Builds a Compensation from a parameter file. Throws ftid::Error (ConfigError naming file and
/// key) if the file is missing or invalid. Non-RT.
using CompensationFactory = std::function<std::unique_ptr<Compensation>(const std::string& path)>;

struct ReloadResult {
  bool ok = false;
  bool applied = false;      ///< the loop has taken the new parameters into use
  std::uint32_t version = 0; ///< parameter version in use afterwards
  std::string message;       ///< empty, or why it failed / that it is still pending
};

/// Empty if `path` is a regular file; otherwise why not ("...: is a FIFO, not a regular file").
/// Never blocks: opens with O_NONBLOCK and checks with fstat.
std::string regularFileProblem(const std::string& path);

class ParameterReloader {
 public:
  ParameterReloader(rt::OwnedSwapSlot<Compensation>* slot, CompensationFactory factory);

  /// Builds from `path` and offers the result to the loop, then waits up to `apply_timeout` for
  /// the loop to take it (0: do not wait). On a build error nothing changes and ok is false.
  /// The production factory (parameterFileFactory) refuses anything but a regular file (FIFO,
  /// device, directory, /proc/self/fd/N of a pipe) before reading it, so a reload never blocks.
  ReloadResult reload(const std::string& path, std::chrono::milliseconds apply_timeout);

  /// Offers an object built elsewhere (a tare) to the loop as reload() does after building.
  ReloadResult offer(std::unique_ptr<Compensation> fresh, std::chrono::milliseconds apply_timeout);

  /// Frees a replaced object if the loop has retired one (call periodically).
  void collect() { slot_->collectRetired(); }

  std::uint32_t failed() const noexcept { return failed_; }
  std::uint32_t succeeded() const noexcept { return succeeded_; }

 private:
  rt::OwnedSwapSlot<Compensation>* slot_;
  CompensationFactory factory_;
  std::uint32_t failed_ = 0;
  std::uint32_t succeeded_ = 0;
};

}  // namespace ftid::daemon
