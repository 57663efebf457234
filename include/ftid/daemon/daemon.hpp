#pragma once
// ftidd's wiring (docs/daemon.md): the process owns real-time set-up, threads own their
// scheduling, and only this class composes drivers, math and transport.
//
//   Daemon d(config);        // nothing opened yet
//   return d.run();          // opens everything, runs until SIGTERM/SIGINT, returns an exit code
//
// run() is three parts (docs/architecture.md, "ftidd's structure"):
//  - set-up (src/daemon/daemon_setup.*): kinematics, parameters, LCM outbox, command verifier,
//    the sensor (retried for connect_timeout_s), the DaemonCycle; throws (the robot is connected
//    by the loop owner's link thread, never waited for at set-up);
//  - the loop owner (ftid/daemon/loop_owner.hpp): the real-time loop thread (SCHED_FIFO if
//    permitted, DaemonCycle under the device-clocked executor) and the link thread that renews a
//    lost robot connection or sensor transport in-process, with backoff;
//  - the supervisor (src/daemon/supervisor.*), the calling thread: signals (SIGHUP = reload
//    parameters, SIGTERM/SIGINT = stop), LCM commands, valid = false while no cycle runs, loop
//    statistics, systemd (READY, WATCHDOG while every thread shows progress, RELOADING,
//    STOPPING, STATUS).
// run() blocks SIGHUP/SIGTERM/SIGINT in the calling thread before it starts any thread, so every
// thread inherits the mask and the supervisor takes them with sigtimedwait(). The LcmOutbox
// publisher thread encodes and publishes what the loop queues.
#include <atomic>
#include <cstdint>
#include <string>

#include "ftid/config/daemon_config.hpp"

namespace ftid_lcm {
class command_t;
}  // namespace ftid_lcm

namespace ftid::transport {
class CommandVerifier;
}  // namespace ftid::transport

namespace ftid::daemon {

struct DaemonRunOptions {
  /// If not empty: record to this LCM log (overrides record.enabled/record.path).
  std::string record_path;
  /// Print a one-line status every this many seconds to stderr (0 = never).
  double status_period_s = 10.0;
  /// How long to keep retrying to open the sensor at start [s] (with the reconnect backoff,
  /// robot.reconnect_backoff_*_s). The robot is not waited for (docs/daemon.md, "Running").
  double connect_timeout_s = 10.0;
};

class Daemon {
 public:
  explicit Daemon(config::DaemonConfig config, DaemonRunOptions options = {});
  /// Runs until SIGTERM/SIGINT (exit code 0) or a fatal loop error (real-time set-up of the loop
  /// thread failed with rt.require_rt: exit code 1). A lost robot link is renewed in-process.
  /// Set-up errors (also: the sensor not reachable within connect_timeout_s) throw.
  int run();

 private:
  config::DaemonConfig config_;
  DaemonRunOptions options_;
};

/// Commands refused since start, by reason (published in loop_stats_t).
struct CommandCounters {
  std::int32_t auth = 0;
  std::int32_t stale = 0;
  std::int32_t replay = 0;
  std::int32_t malformed = 0;
};

/// Checks a received command: authenticator, freshness and replay (verifier), and that
/// RELOAD_PARAMETERS carries no path. Returns "" if it may be executed, else the one-line reason
/// (and counts it).
std::string checkCommand(const ftid_lcm::command_t& command, transport::CommandVerifier* verifier,
                         CommandCounters* counters);

/// Expands strftime patterns in a path with the current local time.
std::string expandTimePattern(const std::string& pattern);

}  // namespace ftid::daemon
