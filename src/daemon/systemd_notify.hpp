#pragma once
// sd_notify wrapper: a no-op when ftid is built without libsystemd or not run under systemd.
#include <cstddef>
#include <cstdint>
#include <string>

namespace ftid::daemon {

/// Sends a notification ("READY=1", "WATCHDOG=1", "STATUS=..."). Returns false if not sent.
bool notifySystemd(const std::string& state);
/// Sends "STATUS=" + printableLine(text, 400): text that quotes the network (the robot link's last
/// error can carry bytes the controller sent) can never add a line such as WATCHDOG=1.
bool notifySystemdStatus(const std::string& text);
/// text as one printable ASCII line of at most max_chars: every byte outside 0x20..0x7e becomes
/// '?', and a longer text is cut and ends in "...". For STATUS= and log lines that quote
/// untrusted bytes.
std::string printableLine(const std::string& text, std::size_t max_chars);
/// Watchdog interval requested by systemd [us], or 0 if the watchdog is not enabled.
std::uint64_t systemdWatchdogUsec();

}  // namespace ftid::daemon
