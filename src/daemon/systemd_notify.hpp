#pragma once
// sd_notify wrapper: a no-op when ftid is built without libsystemd or not run under systemd.
#include <cstdint>
#include <string>

namespace ftid::daemon {

/// Sends a notification ("READY=1", "WATCHDOG=1", "STATUS=..."). Returns false if not sent.
bool notifySystemd(const std::string& state);
/// Watchdog interval requested by systemd [us], or 0 if the watchdog is not enabled.
std::uint64_t systemdWatchdogUsec();

}  // namespace ftid::daemon
