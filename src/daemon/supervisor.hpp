#pragma once
// ftidd's supervisor (private to src/daemon): the thread that called Daemon::run(). It owns no
// device; on a steady 50 ms tick of CLOCK_MONOTONIC it
//  - takes SIGHUP (reload) and SIGTERM/SIGINT (stop) with sigtimedwait();
//  - executes authenticated LCM commands (RELOAD_PARAMETERS, PING, TARE) and answers with ack_t;
//  - publishes compensated_wrench_t with valid = false while no cycle runs (robot silent or the
//    link being renewed by the loop owner);
//  - publishes loop_stats_t (including the link's reconnects and time without a link) and the
//    systemd STATUS line;
//  - feeds the systemd watchdog while every thread shows progress (docs/operations.md, "Link loss
//    and reconnect": the loop's heartbeat, the link thread's, its own tick) and the robot link has
//    not been down for robot.watchdog_silence_s (if set).
#include <signal.h>

#include <chrono>
#include <cstdint>
#include <string>
#include <utility>

#include "daemon_setup.hpp"
#include "ftid/common/types.hpp"
#include "ftid_lcm/ack_t.hpp"
#include "ftid/daemon/daemon.hpp"
#include "ftid/daemon/loop_owner.hpp"

namespace ftid::daemon {

class Supervisor {
 public:
  Supervisor(DaemonSetup* setup, LoopOwner* owner, const sigset_t& signals,
             const DaemonRunOptions& options);
  /// Runs until SIGTERM/SIGINT (returns 0) or the loop thread failed (returns 1).
  int run();

 private:
  struct TareAnswer {
    bool ok = false;
    std::string message;
    Wrench offsets = Wrench::Zero();  ///< in use after an ok tare (ack_t.offsets)
  };
  ReloadResult doReload();
  TareAnswer doTare();
  /// REIDENTIFY (docs/daemon.md, "Re-identification"): fit the change on the recent samples,
  /// validate, and with `apply` write the parameter file atomically and reload it.
  std::pair<bool, std::string> doReidentify(bool apply);
  void handleCommands();
  void publishStats();
  void trackRobotLink(std::uint64_t cycles_now);
  void feedWatchdog();

  using Clock = std::chrono::steady_clock;
  DaemonSetup& s_;
  LoopOwner& owner_;
  sigset_t signals_;
  DaemonRunOptions options_;
  CommandCounters refused_;
  Clock::time_point t0_;
  Clock::duration watchdog_period_{};
  std::uint64_t watchdog_usec_ = 0;
  Clock::time_point next_watchdog_;
  Clock::time_point next_stats_;
  Clock::time_point next_status_;
  Clock::time_point next_refusal_log_;
  std::uint64_t refusals_unlogged_ = 0;
  std::uint64_t last_heartbeat_ = 0;
  std::uint64_t last_cycles_ = 0;
  Clock::time_point last_cycle_time_;
  bool robot_silent_ = false;
  bool ready_sent_ = false;
  bool running_logged_ = false;  ///< "running at N Hz" logged (the first cycle)
  std::int32_t reloads_applied_ = 0;
  std::uint64_t tare_id_ = 0;
  std::int32_t tares_done_ = 0;     // loop_stats_t.tares_done / tares_refused
  std::int32_t tares_refused_ = 0;
  // The answer to the last authenticated command: a resend of it (same request_id and command,
  // signed afresh by a client that missed the ack) is answered again, not executed twice (a
  // second TARE would average a new window and count twice).
  bool have_last_ack_ = false;
  ftid_lcm::ack_t last_ack_{};
  std::uint32_t faults_since_report_ = 0;
  rt::LoopStats prev_stats_;
  rt::LoopStats snap_;
};

}  // namespace ftid::daemon
