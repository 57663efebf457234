// `ftid reidentify`: ask the running ftidd to estimate the payload change from its recent motion
// (a signed REIDENTIFY, docs/daemon.md "Re-identification"), optionally load it. The command goes
// through ftid::daemon::DaemonClient, which publishes it once and never resends it.
#include <cstdio>
#include <iostream>
#include <string>

#include "command.hpp"
#include "ftid/config/daemon_config.hpp"
#include "ftid/daemon/client.hpp"
#include "ftid/fileio/json_text.hpp"

namespace {

const char* const kUsage =
    "usage: ftid reidentify [--apply] [--config FILE] [--key FILE] [--timeout S] [--json]\n"
    "\n"
    "Asks the running ftidd to estimate how the payload changed (an object grasped or released)\n"
    "from the compensated residual of its last monitor.reidentify_window_s seconds (default 4 s) of\n"
    "valid cycles: a weighted least-squares fit of delta mass, delta first moment and delta inertia\n"
    "on the rigid-body regressor, validated (enough motion, mass precise to 0.05 kg, residual after\n"
    "the fit within 2 x monitor.noise_std, a physical mass and inertia). Prints ftidd's answer.\n"
    "The window must contain motion of the arm with the new payload and no contact; with the arm\n"
    "at rest ftidd refuses and says so. Offsets, tilt and other effects are kept.\n"
    "\n"
    "options:\n"
    "  --apply         also load the result: ftidd writes its parameter file atomically (the old one\n"
    "                  kept as PARAMS.yaml.bak, an active tare baked in) and reloads it\n"
    "  --config FILE   ftidd configuration (default /etc/ftid/ftidd.yaml): LCM URL, channels, key\n"
    "  --key FILE      command key to sign with instead of lcm.command_key_path\n"
    "  --timeout S     how long to wait for ftidd's answer (default 5 s)\n"
    "  --json          print {\"ok\", \"message\", \"param_version\"} on stdout\n"
    "\n"
    "exit status: 0 estimated (and with --apply loaded), 1 nothing sent (configuration or key\n"
    "unreadable, LCM), 2 usage error, 3 ftidd refused (its reason: no motion, a contact in the\n"
    "window, an unphysical result, the monitor off, bad authenticator ...), 4 no answer.";

int runReidentify(const std::vector<std::string>& argv) {
  std::string config_path = "/etc/ftid/ftidd.yaml", key_path;
  double timeout_s = 5.0;
  bool json = false, apply = false;
  CLI::App app{"ftid reidentify"};
  app.add_flag("--apply", apply);
  app.add_option("--config", config_path);
  app.add_option("--key", key_path);
  app.add_option("--timeout", timeout_s)->transform(ftid::cli::real({0.0, 600.0, true, false}));
  app.add_flag("--json", json);
  ftid::cli::parse(app, argv);

  const ftid::config::DaemonConfig cfg = ftid::config::loadDaemonConfig(config_path);  // names file and key
  ftid::daemon::DaemonClientOptions options = ftid::daemon::DaemonClientOptions::fromConfig(cfg);
  if (!key_path.empty()) options.key_path = key_path;
  options.local_sources_only = !cfg.lcm.accept_remote;
  ftid::daemon::DaemonClient client(options);
  const ftid::daemon::CommandAck r =
      client.sendCommand(ftid::daemon::DaemonCommand::kReidentify, timeout_s, apply ? "apply" : "");
  if (!r.sent) {
    std::cerr << "ftid reidentify: " << r.message << " (configuration " << cfg.source << "); nothing sent\n";
    return 1;
  }
  if (!r.answered) {
    std::cerr << "ftid reidentify: no answer from ftidd on " << cfg.lcm.channels.ack << " within " << timeout_s
              << " s; is ftidd running with " << cfg.source << " on this host?\n";
    return 4;
  }
  if (json) {
    ftid::Json o = ftid::Json::object();
    o["ok"] = r.ok;
    o["message"] = r.message;
    o["param_version"] = r.param_version;
    std::cout << ftid::jsonText(o) << "\n";
  }
  if (!r.ok) {
    std::cerr << "ftid reidentify: ftidd refused: " << r.message << "\n";
    return 3;
  }
  if (!json) std::cout << "ftidd: " << r.message << " (parameter version " << r.param_version << ")\n";
  return 0;
}

ftid::cli::Registrar reg{{"reidentify", "estimate the payload change from ftidd's recent motion (--apply loads it)",
                          kUsage, &runReidentify}};

}  // namespace
