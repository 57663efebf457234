#include "ftid/daemon/daemon.hpp"

#include <pthread.h>
#include <signal.h>

#include <ctime>
#include <memory>

#include "daemon_setup.hpp"
#include "ftid/daemon/loop_owner.hpp"
#include "ftid/transport/command_auth.hpp"
#include "supervisor.hpp"
#include "systemd_notify.hpp"

namespace ftid::daemon {

std::string checkCommand(const ftid_lcm::command_t& cmd, transport::CommandVerifier* verifier,
                         CommandCounters* counters) {
  const transport::CommandVerdict v = verifier->verify(cmd, transport::realtimeUs());
  std::string why;
  switch (v) {
    case transport::CommandVerdict::kAccepted: break;
    case transport::CommandVerdict::kBadMac:
      ++counters->auth;
      why = verifier->hasKey() ? "bad authenticator (wrong key or altered message)"
                               : "no command key configured (lcm.command_key_path)";
      break;
    case transport::CommandVerdict::kStale:
      ++counters->stale;
      why = "stale: signed outside +-30 s of ftidd's clock or before ftidd started";
      break;
    case transport::CommandVerdict::kReplayed:
      ++counters->replay;
      why = "replayed: sequence not above the last accepted command";
      break;
  }
  if (why.empty() && cmd.command == ftid_lcm::command_t::RELOAD_PARAMETERS && !cmd.argument.empty()) {
    ++counters->malformed;
    why = "RELOAD_PARAMETERS takes no path: ftidd reloads only its configured parameter file";
  }
  if (why.empty() && cmd.command == ftid_lcm::command_t::TARE && !cmd.argument.empty()) {
    ++counters->malformed;
    why = "TARE takes no argument (the window and limits are in ftidd's configuration)";
  }
  if (why.empty() && cmd.command == ftid_lcm::command_t::REIDENTIFY && !cmd.argument.empty() &&
      cmd.argument != "apply") {
    ++counters->malformed;
    why = "REIDENTIFY takes no argument or \"apply\"";
  }
  if (why.empty()) return {};
  return "command " + std::to_string(static_cast<int>(cmd.command)) + " (request " +
         std::to_string(cmd.request_id) + ") refused: " + why;
}

std::string expandTimePattern(const std::string& pattern) {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  localtime_r(&t, &tm);
  char buf[4096];
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wformat-nonliteral"
  const std::size_t n = std::strftime(buf, sizeof buf, pattern.c_str(), &tm);  // user pattern
#pragma GCC diagnostic pop
  return n > 0 ? std::string(buf, n) : pattern;
}

Daemon::Daemon(config::DaemonConfig config, DaemonRunOptions options)
    : config_(std::move(config)), options_(std::move(options)) {}

// ftidd in three parts (docs/architecture.md, "ftidd's structure"): the set-up builds everything
// (and may throw), the loop owner runs the real-time loop and keeps the robot and sensor links,
// the supervisor (this thread) handles signals, commands, statistics and systemd.
int Daemon::run() {
  // Signals: blocked here, before any thread exists, and taken by the supervisor.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGHUP);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  DaemonSetup setup(config_, options_);
  LoopOwner owner(setup.cycle.get(), setup.loop_stats.get(), setup.armConnector(), setup.sensorLink(),
                  setup.loopOwnerOptions(), &logLine);
  setup.outbox->start();
  if (setup.payload_watch) setup.payload_watch->start();
  owner.start(nullptr);  // the link thread connects the robot (docs/daemon.md, "Running")
  Supervisor supervisor(&setup, &owner, signals, options_);
  const int exit_code = supervisor.run();

  notifySystemd("STOPPING=1");
  owner.stop();  // the loop returns within one receive timeout
  if (setup.payload_watch) setup.payload_watch->stop();
  setup.outbox->stop();
  const auto oc = setup.outbox->counters();
  const LinkStatus link = owner.status();
  logLine("stopped after " + std::to_string(setup.cycle->counters().cycles.load()) + " cycles, " +
          std::to_string(oc.published) + " messages published, " + std::to_string(oc.dropped) +
          " dropped, " + std::to_string(link.robot_reconnects) + " robot reconnects");
  return exit_code;
}

}  // namespace ftid::daemon
