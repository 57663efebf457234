// `ftid --identify` (alias `ftid cell-identify`): the one-shot identification on the cell.
#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>

#include "command.hpp"
#include "ftid/cell/cell_identify.hpp"

namespace {

std::atomic<bool> g_abort{false};
extern "C" void onSigint(int) { g_abort.store(true); }

const char* kUsage =
    "usage: ftid --identify [options]\n"
    "\n"
    "Identify the tool on the F/T sensor on the cell: checks that ftidd, the sensor and the robot\n"
    "are ready, asks before moving, moves slowly to the start pose, runs the excitation trajectory\n"
    "(the robot is the clock), records ftidd's synchronised samples, identifies the model, shows the\n"
    "held-out residual per axis and which physical effect is missing (if any), writes the parameter\n"
    "file atomically (previous version kept as .bak) with UR and ros2_control exports, and tells\n"
    "ftidd to reload it (a command signed with the key in lcm.command_key_path: run as root or as a\n"
    "member of the ftid group). Before any motion every target is checked like `ftid check-trajectory`\n"
    "(floor, keep-out, designed ranges): a violation refuses the run, whatever --yes says. The\n"
    "recorded stream must follow the controller's clock (duplicates dropped, a second publisher\n"
    "refuses the run). Ctrl-C stops the arm and keeps the recorded data.\n"
    "\n"
    "options:\n"
    "  --config FILE        ftidd configuration (default /etc/ftid/ftidd.yaml): robot address, LCM,\n"
    "                       parameter file, sensor mount\n"
    "  --trajectory FILE    excitation trajectory (traj.yaml from `ftid design`; default: the shipped\n"
    "                       excitation_<robot>.yaml for the config's URDF (ur10, ur10e): 3 s,\n"
    "                       designed for paper+rigid_body)\n"
    "  --cell FILE          the cell's safety limits (floor, keep-out spheres, joint position, speed\n"
    "                       and acceleration limits; more limits ON TOP of the installed\n"
    "                       /etc/ftid/cell_limits.yaml, which always applies when present: --cell only tightens;\n"
    "                       default: the installed file if it exists,\n"
    "                       else the shipped config/cell_limits.yaml): the trajectory's own constraints\n"
    "                       can only tighten them; each limit is printed with the file it came from\n"
    "  --model M            model to identify (default paper+rigid_body; e.g. paper)\n"
    "  --paper              the paper's method as published: its 10 s trajectory\n"
    "                       (excitation_<robot>_paper.yaml) and the paper model\n"
    "  --params FILE        parameter file to write (default: the config's parameters.path). Another\n"
    "                       file is refused unless --no-reload is given: ftidd loads only its\n"
    "                       configured file (change parameters.path to switch files)\n"
    "  --runs-dir DIR       where recorded runs are kept (default: <params dir>/runs)\n"
    "  --script-port N      URScript port (default 30003)\n"
    "  --register-offset N  RTDE input register offset, 0 or 24 (default 0)\n"
    "  --no-reload          do not ask ftidd to reload\n"
    "  --no-analyze         skip the model-laboratory analysis\n"
    "  --require-rt         refuse to run without real-time scheduling\n"
    "  --yes                do not ask for confirmation before motion (scripts)\n"
    "\n"
    "exit status: 0 identified and written, 1 aborted or failed (the message says why; the arm is\n"
    "stopped and recorded data kept), 2 usage error.";

int run(const std::vector<std::string>& argv) {
  ftid::cell::CellIdentifyOptions o;
  CLI::App app{"ftid --identify"};
  app.add_option("--config", o.config_path);
  app.add_option("--trajectory", o.trajectory_path);
  app.add_option("--cell", o.cell_limits_path);
  app.add_option("--model", o.model);
  app.add_flag("--paper", o.paper);
  app.add_option("--params", o.params_path);
  app.add_option("--runs-dir", o.runs_dir);
  app.add_option("--script-port", o.script_port)->transform(ftid::cli::integer(1, 65535));
  app.add_option("--register-offset", o.register_offset)->transform(ftid::cli::integer(0, 24));
  bool no_reload = false, no_analyze = false;
  app.add_flag("--no-reload", no_reload);
  app.add_flag("--no-analyze", no_analyze);
  app.add_flag("--require-rt", o.require_realtime);
  app.add_flag("--yes", o.assume_yes);
  ftid::cli::parse(app, argv);
  if (o.paper && app.count("--model") == 0) o.model = "paper";
  o.reload_daemon = !no_reload;
  o.analyze = !no_analyze;
  if (o.register_offset != 0 && o.register_offset != 24) throw ftid::cli::UsageError("--register-offset must be 0 or 24");

  struct sigaction sa {};
  sa.sa_handler = onSigint;
  sigaction(SIGINT, &sa, nullptr);
  o.abort = &g_abort;
  const bool tty = ::isatty(STDERR_FILENO) != 0;
  o.print = [](const std::string& s) { std::cout << s << "\n" << std::flush; };
  o.confirm = [](const std::string& q) {
    std::cout << q << std::flush;
    std::string answer;
    if (!std::getline(std::cin, answer)) return false;
    return answer == "y" || answer == "Y" || answer == "yes";
  };
  o.progress = [tty, last_second = -1.0](const std::string& phase, double elapsed, double total) mutable {
    // On a terminal the bar is redrawn in place; in a log, one line per second of motion.
    if (!tty) {
      if (std::floor(elapsed) == last_second) return;
      last_second = std::floor(elapsed);
    }
    const int width = 30;
    const double frac = total > 0 ? std::min(1.0, std::max(0.0, elapsed / total)) : 0.0;
    const int filled = static_cast<int>(frac * width);
    std::string bar(static_cast<std::size_t>(filled), '#');
    bar.resize(width, '.');
    std::fprintf(stderr, "%s[%s] %5.1f / %5.1f s  remaining %5.1f s  %-16s%s", tty ? "\r" : "", bar.c_str(),
                 elapsed, total, total - elapsed, phase.c_str(), tty ? "" : "\n");
  };
  const ftid::cell::CellIdentifyResult r = ftid::cell::runCellIdentify(o);
  if (tty) std::fprintf(stderr, "\n");
  if (r.exit_code == 0) {
    std::cout << "OK: " << r.message << "\n";
  } else {
    std::cerr << "ftid --identify: " << r.message << "\n";
  }
  return r.exit_code;
}

ftid::cli::Registrar reg{{"cell-identify", "one-shot identification on the cell (also: ftid --identify)", kUsage, &run}};

}  // namespace
