// `ftid tare`: re-zero the sensor offsets of a running ftidd (a signed TARE on its command channel,
// docs/daemon.md "Tare", docs/operations.md "Tare from the command line"). The command goes through
// ftid::daemon::DaemonClient (ftid/daemon/client.hpp), which publishes a TARE once and never
// resends it; this file keeps only the argument parsing and the printing.
#include <cstdio>
#include <iostream>
#include <string>

#include "command.hpp"
#include "ftid/config/daemon_config.hpp"
#include "ftid/daemon/client.hpp"
#include "ftid/fileio/json_text.hpp"

namespace {

const char* const kUsage =
    "usage: ftid tare [--config FILE] [--key FILE] [--timeout S] [--json]\n"
    "\n"
    "Re-zero the F/T sensor: asks the running ftidd to re-estimate the offsets f0, t0 at the current\n"
    "pose against the identified payload (signed TARE on its command channel; docs/daemon.md,\n"
    "\"Tare\"), waits for its answer and prints the new offsets. The robot must be at rest and the\n"
    "tool free of contact for parameters.tare_window_s (default 0.25 s): a contact force would\n"
    "become part of the offsets. ftidd keeps the offsets in PARAMETERS.tare.yaml next to its\n"
    "parameter file (they survive a restart); a reload of the parameters (SIGHUP, RELOAD, `ftid\n"
    "--identify`) reverts them. The command is signed with the command key: run as root or as a\n"
    "member of the ftid group.\n"
    "\n"
    "options:\n"
    "  --config FILE   ftidd configuration (default /etc/ftid/ftidd.yaml): LCM URL, command and ack\n"
    "                  channels, the key (lcm.command_key_path), the tare window\n"
    "  --key FILE      command key to sign with instead of lcm.command_key_path\n"
    "  --timeout S     how long to wait for ftidd's answer (default: the tare window + 3 s)\n"
    "  --json          print the answer as one JSON object on stdout (exit status 0 and 3):\n"
    "                  {\"ok\", \"message\", \"param_version\", \"offsets\": {\"f0_x\" .. \"t0_z\"}}\n"
    "\n"
    "exit status:\n"
    "  0  tared: the new offsets are in use (printed, N and Nm in the sensor frame S)\n"
    "  1  nothing sent: the configuration or the key cannot be read (the message names the file),\n"
    "     or LCM cannot be opened\n"
    "  2  usage error\n"
    "  3  ftidd refused the tare; its reason is printed (the robot moves, a cycle without a valid\n"
    "     wrench in the window, no parameters loaded, bad authenticator: wrong key, ...). Nothing\n"
    "     changed\n"
    "  4  no answer from ftidd within the timeout (the message names the channels): is ftidd\n"
    "     running, with this configuration, on this host?";

const char* const kOffsetNames[6] = {"f0_x", "f0_y", "f0_z", "t0_x", "t0_y", "t0_z"};

std::string offsetsText(const double* o) {
  char buf[256];
  std::snprintf(buf, sizeof buf, "f0 = (%.5f, %.5f, %.5f) N, t0 = (%.6f, %.6f, %.6f) Nm", o[0], o[1], o[2], o[3],
                o[4], o[5]);
  return buf;
}

std::string replyJson(const ftid::daemon::CommandAck& a) {
  ftid::Json o = ftid::Json::object();
  o["ok"] = a.ok;
  o["message"] = a.message;
  o["param_version"] = a.param_version;
  if (a.ok) {
    ftid::Json offsets = ftid::Json::object();
    for (int i = 0; i < 6; ++i) offsets[kOffsetNames[i]] = ftid::jsonNumber(a.offsets[i]);
    o["offsets"] = std::move(offsets);
  }
  return ftid::jsonText(o);
}

int runTare(const std::vector<std::string>& argv) {
  std::string config_path = "/etc/ftid/ftidd.yaml", key_path;
  double timeout_s = -1.0;  // default: the configured tare window + 3 s
  bool json = false;
  CLI::App app{"ftid tare"};
  app.add_option("--config", config_path);
  app.add_option("--key", key_path);
  app.add_option("--timeout", timeout_s)->transform(ftid::cli::real({0.0, 600.0, true, false}));
  app.add_flag("--json", json);
  ftid::cli::parse(app, argv);

  const ftid::config::DaemonConfig cfg = ftid::config::loadDaemonConfig(config_path);  // names file and key
  if (timeout_s < 0.0) timeout_s = cfg.parameters.tare_window_s + 3.0;
  ftid::daemon::DaemonClientOptions options = ftid::daemon::DaemonClientOptions::fromConfig(cfg);
  if (!key_path.empty()) options.key_path = key_path;
  options.local_sources_only = !cfg.lcm.accept_remote;
  ftid::daemon::DaemonClient client(options);
  const ftid::daemon::CommandAck r = client.sendCommand(ftid::daemon::DaemonCommand::kTare, timeout_s);
  if (!r.sent) {
    const bool key_problem = r.message.rfind("cannot sign", 0) == 0;
    std::cerr << "ftid tare: " << r.message << " (configuration " << cfg.source
              << (key_problem && key_path.empty() ? "; or give --key FILE" : "") << "); nothing sent\n";
    return 1;
  }
  if (!r.answered) {
    char secs[32];
    std::snprintf(secs, sizeof secs, "%.1f", timeout_s);
    std::cerr << "ftid tare: no answer from ftidd on " << cfg.lcm.channels.ack << " within " << secs
              << " s (TARE sent on " << cfg.lcm.channels.command << ", " << cfg.lcm.url
              << "); is ftidd running with " << cfg.source << " on this host?\n";
    return 4;
  }
  if (json) std::cout << replyJson(r) << "\n";
  if (!r.ok) {
    std::cerr << "ftid tare: ftidd refused the tare: " << r.message << "\n";
    return 3;
  }
  if (!json) {
    std::cout << "tared: " << offsetsText(r.offsets.data()) << " (sensor frame S), parameter version "
              << r.param_version << "\n"
              << "ftidd: " << r.message << "\n";
  }
  return 0;
}

ftid::cli::Registrar reg{{"tare", "re-zero the sensor offsets of the running ftidd (robot at rest)", kUsage, &runTare}};

}  // namespace
