// `ftid sim-robot`: a simulated UR10 / UR10e controller on loopback (ftid::simrobot).
#include <pthread.h>

#include <csignal>
#include <cstdio>
#include <iostream>
#include <sstream>

#include "command.hpp"
#include "ftid/common/error.hpp"
#include "ftid/simrobot/sim_robot.hpp"

namespace {

const char* kUsage =
    "usage: ftid sim-robot [--model ur10|ur10e] [--host 127.0.0.1] [--rtde-port 30004]\n"
    "                      [--dashboard-port 29999] [--script-port 30003] [--q0 q1,q2,q3,q4,q5,q6]\n"
    "                      [--fault-after SECONDS:KIND[:COUNT]] [--verbose]\n"
    "\n"
    "Runs a simulated Universal Robots controller until SIGINT/SIGTERM (Ctrl-C):\n"
    "  RTDE (protocol v2) on --rtde-port, the dashboard server subset on --dashboard-port and a\n"
    "  script port that accepts ftid's servo program and ur_rtde's rtde_control program.\n"
    "  ur10  = CB3, software 3.15.8, 125 Hz;  ur10e = e-Series, software 5.11.1, 500 Hz.\n"
    "  Port 0 picks a free port; the ports in use are printed at start.\n"
    "\n"
    "options:\n"
    "  --q0 LIST           initial joint angles [rad] (default 0,-1.5708,1.5708,-1.5708,-1.5708,0)\n"
    "  --fault-after S:K   inject fault K S seconds (controller time) after a program first starts;\n"
    "                      K = protective_stop | estop | program_stop | drop | late | disconnect | stall,\n"
    "                      COUNT = packages for drop/late/stall (default 10). May be repeated.\n"
    "  --verbose           log connections, programs and faults to stderr\n"
    "\n"
    "Faults can also be injected at run time through the dashboard port, e.g.\n"
    "  echo 'sim protective_stop' | nc 127.0.0.1 29999     (also: sim drop 20, sim disconnect)\n"
    "Tracking model, limits and protocol details: docs/robot.md.\n"
    "\n"
    "Exit status: 0 stopped by SIGINT/SIGTERM, 1 an unknown --model or fault kind, a --host that is\n"
    "not an IPv4 address or a port that cannot be listened on (the message says which), 2 usage\n"
    "error (unknown option, bad number).";

int runSimRobot(const std::vector<std::string>& argv) {
  namespace cli = ftid::cli;
  ftid::simrobot::SimRobotConfig cfg;
  std::string model = "ur10";
  int rtde_port = 30004, dashboard_port = 29999, script_port = 30003;
  std::vector<double> q0;
  std::vector<std::string> faults;
  CLI::App app{"ftid sim-robot"};
  app.add_option("--model", model);
  app.add_option("--host", cfg.host);
  // Port 0: the simulator picks a free port (and prints it).
  app.add_option("--rtde-port", rtde_port)->transform(cli::integer(0, 65535));
  app.add_option("--dashboard-port", dashboard_port)->transform(cli::integer(0, 65535));
  app.add_option("--script-port", script_port)->transform(cli::integer(0, 65535));
  cli::addReals(app, "--q0", q0, 6);
  cli::addRepeatable(app, "--fault-after", faults);
  app.add_flag("--verbose", cfg.verbose);
  cli::parse(app, argv);
  cfg.model = ftid::simrobot::parseRobotModel(model);
  cfg.rtde_port = static_cast<std::uint16_t>(rtde_port);
  cfg.dashboard_port = static_cast<std::uint16_t>(dashboard_port);
  cfg.script_port = static_cast<std::uint16_t>(script_port);
  for (std::size_t i = 0; i < q0.size(); ++i) cfg.q0[static_cast<int>(i)] = q0[i];
  for (const auto& f : faults) {  // SECONDS:KIND[:COUNT]
    std::stringstream ss(f);
    std::string when, kind, count;
    std::getline(ss, when, ':');
    std::getline(ss, kind, ':');
    std::getline(ss, count, ':');
    ftid::simrobot::ScheduledFault sf;
    sf.after_s = cli::parseReal(when, "--fault-after " + f + ": SECONDS", cli::nonNegative());
    if (!count.empty()) sf.count = static_cast<int>(cli::parseInteger(count, "--fault-after " + f + ": COUNT", 1, 1000000000));
    sf.kind = ftid::simrobot::parseFaultKind(kind);
    cfg.scheduled_faults.push_back(sf);
  }

  // Block the signals before any thread starts so only sigwait() below receives them.
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);

  ftid::simrobot::SimRobot sim(cfg);
  sim.start();
  std::printf("sim-robot: %s (software %s, %.0f Hz) listening on %s: RTDE %u, dashboard %u, scripts %u\n",
              cfg.model == ftid::simrobot::RobotModel::kUR10 ? "UR10 CB3" : "UR10e e-Series",
              sim.versionString().c_str(), 1.0 / sim.period(), cfg.host.c_str(), sim.rtdePort(), sim.dashboardPort(),
              sim.scriptPort());
  std::printf("sim-robot: Ctrl-C to stop\n");
  std::fflush(stdout);
  int sig = 0;
  sigwait(&set, &sig);
  const auto snap = sim.snapshot();
  sim.stop();
  std::printf("sim-robot: stopped after %llu ticks (last event: %s)\n", static_cast<unsigned long long>(snap.ticks),
              snap.last_event.empty() ? "none" : snap.last_event.c_str());
  return 0;
}

}  // namespace

static ftid::cli::Registrar reg{{"sim-robot", "simulated UR10/UR10e controller (RTDE, dashboard, scripts)",
                                 kUsage, &runSimRobot}};
