// `ftid demo`: the whole cell against the simulators (ftid::cell::runDemo), or with --offline the
// paper-only demo: simulate the paper's cell, identify the 12 parameters, compare with the truth
// and show the compensated residual.
#include <string>
#include <vector>

#include "command.hpp"
#include "ftid/common/default_files.hpp"
#include "ftid/cell/demo.hpp"

namespace {

const char* const kUsage =
    "usage: ftid demo [--workdir DIR] [--hidden-effect NAME] [--no-netns] [--seed N]\n"
    "       ftid demo --scenario payload-change [--workdir DIR] [--no-netns] [--seed N]\n"
    "       ftid demo --offline [--seed N] [--robot URDF] [--full-physics]\n"
    "\n"
    "The demo cell, on loopback inside a private network namespace: starts the UR10 controller\n"
    "simulator, the CAN F/T+IMU sensor simulator (the paper's payload with full rigid-body physics,\n"
    "sensor noise and one hidden effect the default model lacks; it prints what it simulates) and\n"
    "ftidd. Runs `ftid --identify` as shipped (model paper+rigid_body, the 3 s trajectory designed\n"
    "for it; it prints the accuracy it expects before it moves) and shows the identified payload\n"
    "beside the simulator's truth; streams a few seconds of live compensated wrench while the tool\n"
    "is pushed (only the push remains); the model laboratory names the hidden effect from what the\n"
    "default model leaves unexplained, a second identification adds it, the held-out error falls and\n"
    "the live residual is shown again. Prints where the parameters, recorded runs, reports and logs\n"
    "are. About a minute after the build.\n"
    "\n"
    "  --workdir DIR        configs, runs, parameters and logs (default out/demo)\n"
    "  --hidden-effect E    the sensor simulator's hidden effect (default temperature_drift; also\n"
    "                       cable, time_drift, sensor_delay)\n"
    "  --no-netns           use the host network instead of a private namespace\n"
    "  --seed N             the sensor simulator's noise seed (default 1)\n"
    "  --scenario S         'lab' (default: the story above) or 'payload-change': the same cell\n"
    "                       with no hidden effect; after the identification the arm moves, 3 s in\n"
    "                       the simulated gripper takes a 0.6 kg object, ftidd's payload monitor\n"
    "                       flags it on the wrench, `ftid reidentify --apply` restores the\n"
    "                       compensation while the arm moves, and a second motion shows it\n"
    "                       (docs/daemon.md \"Payload monitor\")\n"
    "\n"
    "--offline: simulates a 10 s paper-style excitation run of a UR10 carrying the paper's payload\n"
    "(Table 2: mass, centre of mass, sensor offsets, base tilt) with 0.05 N / 0.01 Nm sensor noise,\n"
    "identifies the 12 parameters with the paper's dynamic method, prints them beside the truth\n"
    "(error in units of the reported standard error), and compensates a second, independent run.\n"
    "\n"
    "  --seed N          noise seed (default 1)\n"
    "  --robot URDF      robot description (default: the shipped ur10.urdf, docs/operations.md)\n"
    "  --full-physics    simulate full rigid-body dynamics (rotational inertia), which the paper's\n"
    "                    model omits; default is the paper's physics\n"
    "\n"
    "exit status: 0 the demo showed what it says, 1 a step failed or a figure was not as expected\n"
    "(the output says which), 2 usage error.";

int runDemo(const std::vector<std::string>& argv) {
  namespace cli = ftid::cli;
  ftid::cell::DemoOptions cell;
  ftid::cell::OfflineDemoOptions opt;
  bool offline = false, no_netns = false;
  std::string scenario = "lab";
  CLI::App app{"ftid demo"};
  app.add_flag("--offline", offline);
  CLI::Option* workdir = app.add_option("--workdir", cell.workdir);
  CLI::Option* hidden = app.add_option("--hidden-effect", cell.hidden_effect);
  CLI::Option* netns = app.add_flag("--no-netns", no_netns);
  CLI::Option* scen = app.add_option("--scenario", scenario)->check(CLI::IsMember({"lab", "payload-change"}));
  app.add_option("--seed", opt.seed)->transform(cli::count());
  CLI::Option* robot = app.add_option("--robot", opt.robot_urdf);
  CLI::Option* physics = app.add_flag("--full-physics", opt.full_physics);
  cli::parse(app, argv);
  // Each mode takes only its own options.
  for (const CLI::Option* o : offline ? std::vector<const CLI::Option*>{workdir, hidden, netns, scen}
                                      : std::vector<const CLI::Option*>{robot, physics}) {
    if (o->count() > 0) {
      throw cli::UsageError(o->get_name() + (offline ? " is not an option of the offline demo"
                                                     : " needs --offline"));
    }
  }
  if (!offline) {
    cell.private_netns = !no_netns;
    if (opt.seed > 2147483647u) {
      throw cli::UsageError("--seed: '" + std::to_string(opt.seed) + "' is not a whole number in 0..2147483647");
    }
    cell.seed = static_cast<int>(opt.seed);
    if (scenario == "payload-change") {
      if (hidden->count() > 0) throw cli::UsageError("--hidden-effect is not an option of --scenario payload-change");
      return ftid::cell::runPayloadChangeDemo(cell);
    }
    return ftid::cell::runDemo(cell);
  }
  return ftid::cell::runOfflineDemo(opt);
}

ftid::cli::Registrar reg{{"demo", "the demo cell against the simulators (--offline: paper-only simulation)", kUsage, &runDemo}};

}  // namespace
