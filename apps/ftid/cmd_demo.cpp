// `ftid demo`: the whole cell against the simulators (ftid::cell::runDemo), or with --offline the
// paper-only demo: simulate the paper's cell, identify the 12 parameters, compare with the truth
// and show the compensated residual.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>

#include "command.hpp"
#include "ftid/common/default_files.hpp"
#include "ftid/cell/demo.hpp"
#include "ftid/common/error.hpp"
#include "ftid/compensate/compensator.hpp"
#include "ftid/samples/context.hpp"
#include "ftid/identify/offline.hpp"
#include "ftid/identify/paper_method.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/sim/cell_sim.hpp"

namespace {

const char* const kUsage =
    "usage: ftid demo [--workdir DIR] [--hidden-effect NAME] [--no-netns] [--seed N]\n"
    "       ftid demo --offline [--seed N] [--robot URDF] [--full-physics]\n"
    "\n"
    "The demo cell, on loopback inside a private network namespace: starts the UR10 controller\n"
    "simulator, the CAN F/T+IMU sensor simulator (the paper's payload plus a hidden effect the\n"
    "paper's model lacks) and ftidd; runs `ftid --identify` with the paper model; the model\n"
    "laboratory names the missing effect; a second identification adds it and the held-out error\n"
    "falls; finally a few seconds of live compensated wrench while the tool is pushed. Prints where\n"
    "the parameters, recorded runs, reports and logs are.\n"
    "\n"
    "  --workdir DIR        configs, runs, parameters and logs (default out/demo)\n"
    "  --hidden-effect E    the sensor simulator's hidden effect (default temperature_drift; also\n"
    "                       cable, time_drift, sensor_delay, rigid_body)\n"
    "  --no-netns           use the host network instead of a private namespace\n"
    "\n"
    "--offline: simulates a 10 s paper-style excitation run of a UR10 carrying the paper's payload\n"
    "(Table 2: mass, centre of mass, sensor offsets, base tilt) with 0.05 N / 0.01 Nm sensor noise,\n"
    "identifies the 12 parameters with the paper's dynamic method, prints them beside the truth\n"
    "(error in units of the reported standard error), and compensates a second, independent run.\n"
    "\n"
    "  --seed N          noise seed (default 1)\n"
    "  --robot URDF      robot description (default: the shipped ur10.urdf, docs/operations.md)\n"
    "  --full-physics    simulate full rigid-body dynamics (rotational inertia), which the paper's\n"
    "                    model omits; default is the paper's physics";

struct DemoOptions {
  std::uint64_t seed = 1;
  std::string robot_urdf;
  bool full_physics = false;
};

double truthOf(const std::string& name) {
  using P = ftid::sim::PaperPayload;
  constexpr double kDeg = 3.141592653589793 / 180.0;
  const char* ax = "xyz";
  for (int i = 0; i < 3; ++i) {
    if (name == std::string("com_") + ax[i]) return P::centreOfMass()(i);
    if (name == std::string("f0_") + ax[i]) return P::forceOffset()(i);
    if (name == std::string("t0_") + ax[i]) return P::torqueOffset()(i);
  }
  if (name == "mass") return P::kMass_kg;
  if (name == "weight") return P::kWeight_N;
  if (name == "tilt_u") return P::kTiltU_deg * kDeg;
  if (name == "tilt_v") return P::kTiltV_deg * kDeg;
  return std::nan("");
}

int runPaperDemo(const DemoOptions& opt) {
  using namespace ftid;
  const std::string urdf = opt.robot_urdf.empty() ? defaultRobotUrdf() : opt.robot_urdf;
  std::cerr << "demo: robot " << urdf << "\n";
  sim::CellSimConfig cfg = sim::paperCellConfig(model::RobotKinematics::fromUrdfFile(urdf));
  cfg.full_rigid_body = opt.full_physics;
  cfg.seed = opt.seed;
  cfg.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  std::cerr << "demo: simulating 10 s excitation at 125 Hz (" << (opt.full_physics ? "full rigid-body" : "paper")
            << " physics, noise 0.05 N / 0.01 Nm, seed " << opt.seed << ")\n";
  const logio::LogData log = sim::CellSim(cfg).run();
  const samples::ContextSet contexts = samples::buildContexts(log, *cfg.robot);
  std::cerr << "demo: identifying (paper, dynamic method) from " << contexts.size() << " samples\n";
  const identify::PaperResult r = identify::identifyPaper(contexts.samples);

  std::printf("%-8s %12s %12s %10s %8s  %s\n", "param", "truth", "identified", "std", "err/std", "unit");
  for (const char* name : {"weight", "mass", "com_x", "com_y", "com_z", "f0_x", "f0_y", "f0_z", "t0_x", "t0_y",
                           "t0_z", "tilt_u", "tilt_v"}) {
    for (const auto& p : r.params) {
      if (p.name != name) continue;
      const double truth = truthOf(name);
      std::printf("%-8s %12.6f %12.6f %10.2g %8.2f  %s\n", name, truth, p.value, p.std,
                  p.std > 0 ? (p.value - truth) / p.std : 0.0, p.unit.c_str());
    }
  }
  std::printf("condition numbers: force stage %.3g, torque stage %.3g\n", r.condition_force, r.condition_torque);

  // Compensate an independent run (new noise) with the identified parameters.
  cfg.seed = opt.seed + 1000;
  std::cerr << "demo: compensating an independent run (seed " << cfg.seed << ")\n";
  const samples::ContextSet check = samples::buildContexts(sim::CellSim(cfg).run(), *cfg.robot);
  const params::ParameterSet set = r.toParameterSet();
  const effects::Model model = effects::Model::fromName(set.model);
  compensate::Compensator comp(model, params::thetaFor(model, set), params::nonlinearFor(model, set));
  Vec6 raw = Vec6::Zero(), residual = Vec6::Zero();
  for (const auto& ctx : check.samples) {
    Wrench contact;
    if (comp.compute(ctx, &contact, nullptr) != Status::kOk) throw Error("compensation rejected a sample");
    raw += ctx.wrench_S.cwiseAbs2();
    residual += contact.cwiseAbs2();
  }
  const double n = static_cast<double>(check.size());
  raw = (raw / n).cwiseSqrt();
  residual = (residual / n).cwiseSqrt();
  std::printf("%-6s %12s %14s %12s\n", "axis", "raw RMS", "compensated", "noise");
  for (int a = 0; a < 6; ++a) {
    std::printf("%-6s %12.4f %14.4f %12.4f\n", kWrenchAxisNames[a], raw(a), residual(a), cfg.noise.wrench_std(a));
  }
  return 0;
}

int runDemo(const std::vector<std::string>& argv) {
  ftid::cli::Args args(argv, kUsage);
  if (!args.flag("--offline")) {
    ftid::cell::DemoOptions cell;
    cell.workdir = args.value("--workdir", cell.workdir);
    cell.hidden_effect = args.value("--hidden-effect", cell.hidden_effect);
    cell.private_netns = !args.flag("--no-netns");
    cell.seed = std::stoi(args.value("--seed", "1"));
    args.finish();
    return ftid::cell::runDemo(cell);
  }
  DemoOptions opt;
  const std::string seed = args.value("--seed", "1");
  opt.robot_urdf = args.value("--robot");
  opt.full_physics = args.flag("--full-physics");
  args.finish();
  try {
    std::size_t used = 0;
    opt.seed = std::stoull(seed, &used);
    if (used != seed.size()) throw std::invalid_argument(seed);
  } catch (const std::exception&) {
    throw ftid::cli::UsageError("--seed needs a non-negative integer, not '" + seed + "'");
  }
  return runPaperDemo(opt);
}

ftid::cli::Registrar reg{{"demo", "the demo cell against the simulators (--offline: paper-only simulation)", kUsage, &runDemo}};

}  // namespace
