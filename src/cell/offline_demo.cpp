// `ftid demo --offline` (demo.hpp): simulate the paper's cell, identify the 12 parameters with the
// paper's dynamic method, compare them with the truth and compensate an independent run.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>

#include "ftid/cell/demo.hpp"
#include "ftid/common/default_files.hpp"
#include "ftid/common/error.hpp"
#include "ftid/compensate/compensator.hpp"
#include "ftid/samples/context.hpp"
#include "ftid/identify/offline.hpp"
#include "ftid/identify/paper_method.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/sim/cell_sim.hpp"

namespace ftid::cell {

namespace {

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

}  // namespace

int runOfflineDemo(const OfflineDemoOptions& opt) {
  using namespace ftid;
  const std::string urdf = opt.robot_urdf.empty() ? ftid::defaultRobotUrdf() : opt.robot_urdf;
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

}  // namespace ftid::cell
