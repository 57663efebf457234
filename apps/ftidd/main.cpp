// ftidd: the long-running compensation daemon (docs/daemon.md). Parses arguments, loads and
// validates the configuration, and runs ftid::daemon::Daemon. No logic here.
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "cli_args.hpp"

#include "ftid/common/error.hpp"
#include "ftid/config/daemon_config.hpp"
#include "ftid/daemon/daemon.hpp"
#include "ftid/daemon/plausibility.hpp"

namespace {

constexpr const char* kDefaultConfig = "/etc/ftid/ftidd.yaml";

void printHelp() {
  std::printf(
      "usage: ftidd [--config FILE] [--check-config] [--record FILE] [--connect-timeout S]\n"
      "       ftidd --version | --help\n"
      "\n"
      "Real-time payload compensation daemon. Every robot state packet (UR RTDE, the loop's\n"
      "clock) it pairs with the F/T+IMU sensor (CAN) at the robot's sample time: the sensor\n"
      "samples are put on the robot clock and interpolated to it (docs/daemon.md \"Time base\").\n"
      "It removes the identified payload's gravity and inertia with the parameters from\n"
      "parameters.path, and publishes over LCM:\n"
      "  FTID_WRENCH  compensated_wrench_t  raw, modelled and contact wrench, validity, faults\n"
      "  FTID_CYCLE   cycle_sample_t        robot state + raw sensor sample (for identification)\n"
      "  FTID_STATS   loop_stats_t          loop statistics, once per lcm.stats_period_s\n"
      "  FTID_ACK     ack_t                 answers to command_t on FTID_COMMAND\n"
      "(channel names are configurable; message fields are documented in docs/daemon.md).\n"
      "\n"
      "options:\n"
      "  --config FILE        configuration (default %s); see config/ftidd.yaml\n"
      "  --check-config       load and validate the configuration, print it, exit 0 (or 2)\n"
      "  --record FILE        record every published message to an LCM log (strftime patterns\n"
      "                       allowed); convert it with `ftid lcm-to-csv FILE --out run.csv`\n"
      "  --connect-timeout S  at start, keep retrying to open the sensor for S seconds (10), with\n"
      "                       robot.reconnect_backoff_min_s/_max_s between tries, then exit 1. The\n"
      "                       robot is not waited for: ftidd starts without it (valid = false) and\n"
      "                       connects when it answers, with the same backoff\n"
      "  --version            print the version and exit\n"
      "  --help               this text\n"
      "\n"
      "signals: SIGHUP reloads the parameter file without missing a cycle (a bad file is\n"
      "rejected and the current parameters stay); SIGTERM/SIGINT stop cleanly.\n"
      "commands (signed command_t on FTID_COMMAND): RELOAD_PARAMETERS, PING, and TARE, which\n"
      "re-estimates only the offsets at the current pose (robot at rest), keeps them in\n"
      "PARAMETERS.tare.yaml and is reverted by a reload (docs/daemon.md, \"Tare\"; `ftid tare`).\n"
      "links: a lost robot connection (TCP keepalive, or no state package for\n"
      "robot.reconnect_after_silence_s) or a closed sensor transport is renewed in-process with\n"
      "backoff; meanwhile FTID_WRENCH carries valid = false at 20 Hz (docs/operations.md,\n"
      "\"Link loss and reconnect\").\n"
      "systemd: Type=notify; READY (set-up done and the loop running; the robot link may still be\n"
      "down, STATUS says so and why), WATCHDOG (only while the loop, link and supervisor threads\n"
      "make progress, and robot.watchdog_silence_s if set), RELOADING, STOPPING, STATUS.\n"
      "exit codes: 0 stopped by a signal, 1 runtime failure (sensor unreachable at start,\n"
      "device or real-time set-up error), 2 bad command line or configuration.\n",
      kDefaultConfig);
}

}  // namespace

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  for (const auto& a : args) {  // --help and --version win over everything else
    if (a == "--help" || a == "-h") {
      printHelp();
      return 0;
    }
  }
  std::string config_path = kDefaultConfig;
  bool check_only = false;
  bool version = false;
  ftid::daemon::DaemonRunOptions options;
  CLI::App app{"ftidd"};
  app.add_option("--config", config_path);
  app.add_flag("--check-config", check_only);
  app.add_option("--record", options.record_path);
  app.add_option("--connect-timeout", options.connect_timeout_s)->transform(ftid::cli::real(ftid::cli::nonNegative()));
  app.add_flag("--version", version);
  try {
    ftid::cli::parse(app, args);
  } catch (const ftid::cli::UsageError& e) {
    std::fprintf(stderr, "ftidd: %s (see ftidd --help)\n", e.what());
    return 2;
  }
  if (version) {
    std::printf("ftidd %s\n", FTID_VERSION);
    return 0;
  }

  ftid::config::DaemonConfig config;
  try {
    config = ftid::config::loadDaemonConfig(config_path);
  } catch (const ftid::ConfigError& e) {
    std::fprintf(stderr, "ftidd: %s\n", e.what());
    return 2;
  }
  for (const auto& w : config.warnings) std::fprintf(stderr, "ftidd: warning: %s\n", w.c_str());
  if (check_only) {
    try {
      ftid::daemon::checkSensorDescription(config);
    } catch (const ftid::ConfigError& e) {
      std::fprintf(stderr, "ftidd: %s: %s\n", config_path.c_str(), e.what());
      return 2;
    }
    std::printf("%sconfiguration OK%s\n", ftid::config::describeDaemonConfig(config).c_str(),
                config.warnings.empty() ? "" : " (with warnings, see above)");
    return 0;
  }
  try {
    ftid::daemon::Daemon daemon(config, options);
    return daemon.run();
  } catch (const ftid::ConfigError& e) {
    std::fprintf(stderr, "ftidd: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ftidd: %s\n", e.what());
    return 1;
  }
}
