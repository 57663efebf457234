#include "systemd_notify.hpp"

#include <algorithm>

#ifdef FTID_HAVE_SYSTEMD
#include <systemd/sd-daemon.h>
#endif

namespace ftid::daemon {

bool notifySystemd(const std::string& state) {
#ifdef FTID_HAVE_SYSTEMD
  return sd_notify(0, state.c_str()) > 0;
#else
  (void)state;
  return false;
#endif
}

std::string printableLine(const std::string& text, std::size_t max_chars) {
  std::string out;
  out.reserve(std::min(text.size(), max_chars));
  for (const char ch : text) {
    if (out.size() == max_chars) {
      if (max_chars >= 3) out.replace(max_chars - 3, 3, "...");
      break;
    }
    const auto u = static_cast<unsigned char>(ch);
    out.push_back(u >= 0x20 && u <= 0x7e ? ch : '?');
  }
  return out;
}

bool notifySystemdStatus(const std::string& text) { return notifySystemd("STATUS=" + printableLine(text, 400)); }

std::uint64_t systemdWatchdogUsec() {
#ifdef FTID_HAVE_SYSTEMD
  std::uint64_t usec = 0;
  if (sd_watchdog_enabled(0, &usec) > 0) return usec;
#endif
  return 0;
}

}  // namespace ftid::daemon
