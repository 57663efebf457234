#include "systemd_notify.hpp"

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

std::uint64_t systemdWatchdogUsec() {
#ifdef FTID_HAVE_SYSTEMD
  std::uint64_t usec = 0;
  if (sd_watchdog_enabled(0, &usec) > 0) return usec;
#endif
  return 0;
}

}  // namespace ftid::daemon
