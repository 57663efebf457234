// Benchmark of the excitation-trajectory designer (docs/design.md; figures in docs/performance.md,
// section "Trajectory design").
//
//   1. design a 10 s, 5-harmonic trajectory for joints 4-6 with the paper model (target < 60 s):
//      wall time, condition number vs the random-Fourier baseline and the static six-pose method
//   2. shortest duration meeting mass std < 0.5 % and com std < 1 mm at noise 0.05 N / 0.01 Nm
//   3. check of 2 by simulation: first-principles simulator + identification, several noise seeds
//
// Run from the source root. usage: bench_design [--budget S] [--search-budget S] [--seeds N]
// [--robot URDF] [--config FILE]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include "ftid/design/designer.hpp"
#include "ftid/design/excitation_metric.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/samples/context.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/sim/cell_sim.hpp"

namespace {

using namespace ftid;

double arg(int argc, char** argv, const std::string& name, double def) {
  for (int i = 1; i + 1 < argc; ++i) {
    if (argv[i] == name) return std::atof(argv[i + 1]);
  }
  return def;
}
std::string sarg(int argc, char** argv, const std::string& name, const std::string& def) {
  for (int i = 1; i + 1 < argc; ++i) {
    if (argv[i] == name) return argv[i + 1];
  }
  return def;
}

struct SimErrors {
  double mass_rel_rms = 0.0;  // relative
  double com_rms = 0.0;       // [m], RMS over axes and seeds
};

SimErrors simulate(const model::RobotKinematics& kin, const trajectory::FourierTrajectory& tr,
                   int seeds, const std::string& model_name = "paper",
                   bool full_rigid_body = true) {
  const auto model = effects::Model::fromName(model_name);
  const double m = sim::PaperPayload::kMass_kg;
  const Vec3 c = sim::PaperPayload::centreOfMass();
  double sm = 0.0, sc = 0.0;
  for (int s = 0; s < seeds; ++s) {
    sim::CellSimConfig cfg = sim::paperCellConfig(kin);
    cfg.trajectory = tr;
    cfg.duration_s = tr.duration();
    cfg.seed = 1000 + static_cast<std::uint64_t>(s);
    cfg.full_rigid_body = full_rigid_body;
    cfg.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
    const auto log = sim::CellSim(cfg).run();
    const auto ctx = samples::buildContexts(log, kin);
    const auto fit = identify::fitModel(model, ctx.samples);
    const double em = (fit.value("mass") - m) / m;
    sm += em * em;
    sc += std::pow(fit.value("com_x") - c.x(), 2) + std::pow(fit.value("com_y") - c.y(), 2) +
          std::pow(fit.value("com_z") - c.z(), 2);
  }
  return {std::sqrt(sm / seeds), std::sqrt(sc / (3.0 * seeds))};
}

}  // namespace

int main(int argc, char** argv) {
  const std::string robot = sarg(argc, argv, "--robot", "config/ur10.urdf");
  const std::string config = sarg(argc, argv, "--config", "config/design.yaml");
  const double budget = arg(argc, argv, "--budget", 45.0);
  const double search_budget = arg(argc, argv, "--search-budget", 80.0);
  const int seeds = static_cast<int>(arg(argc, argv, "--seeds", 5));
  const auto kin = model::RobotKinematics::fromUrdfFile(robot);

  design::DesignOptions o;
  o.robot_path = robot;
  o.model = sarg(argc, argv, "--model", "paper");
  o.duration_s = arg(argc, argv, "--duration", 10.0);
  o.harmonics = static_cast<int>(arg(argc, argv, "--harmonics", 5));
  if (sarg(argc, argv, "--objective", "cond") == "dopt")
    o.objective = design::Objective::kDOptimality;
  const bool skip_search = arg(argc, argv, "--skip-search", 0) != 0.0;
  o.time_budget_s = budget;
  o.constraints = design::loadDesignConstraints(config, kin, o.q0);
  o.progress = &std::cerr;

  std::printf("== 1. design: %.3g s, %d harmonics, joints 4-6, model %s, budget %.0f s\n",
              o.duration_s, o.harmonics, o.model.c_str(), budget);
  const auto t0 = std::chrono::steady_clock::now();
  const design::DesignResult r = design::designExcitation(o, kin);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("wall time %.1f s (optimisation %.1f s), evaluations %ld + %ld\n", wall, r.elapsed_s,
              r.global_evals, r.local_evals);
  std::printf(
      "condition number designed %.4g | random median (%d) %.4g -> %.1fx | static six-pose %.4g -> "
      "%.2fx\n",
      r.condition_number, r.baselines.random_count, r.baselines.random_median_condition,
      r.baselines.random_median_condition / r.condition_number, r.baselines.static_condition,
      r.baselines.static_condition / r.condition_number);
  std::printf(
      "dense check: %s; predicted std mass %.3g kg (%.3g %%), com_x/y/z %.3g/%.3g/%.3g mm\n",
      r.check.ok() ? "ok" : "VIOLATED", r.predicted_std.at("mass"),
      100.0 * r.predicted_std.at("mass") / sim::PaperPayload::kMass_kg,
      1e3 * r.predicted_std.at("com_x"), 1e3 * r.predicted_std.at("com_y"),
      1e3 * r.predicted_std.at("com_z"));
  {
    for (bool full : {false, true}) {
      const SimErrors e = simulate(kin, r.file.toTrajectory(), seeds, o.model, full);
      const SimErrors p = simulate(kin, sim::paperExcitationTrajectory(), seeds, "paper", full);
      std::printf("simulated identification (%d seeds, %s physics, noise 0.05 N / 0.01 Nm):\n",
                  seeds, full ? "full rigid-body" : "paper-model");
      std::printf("  designed (fit %s):  mass RMS error %.3g %%, com RMS error %.3g mm\n",
                  o.model.c_str(), 100 * e.mass_rel_rms, 1e3 * e.com_rms);
      std::printf(
          "  paper-style 10 s (fit paper):  mass RMS error %.3g %%, com RMS error %.3g mm\n",
          100 * p.mass_rel_rms, 1e3 * p.com_rms);
    }
  }

  if (skip_search) return 0;
  std::printf(
      "\n== 2. shortest duration, model %s: mass std <= 0.5 %%, com std <= 1 mm (budget %.0f s)\n",
      o.model.c_str(), search_budget);
  design::DesignOptions s = o;
  s.time_budget_s = search_budget;
  s.progress = nullptr;
  s.baseline_seeds = 0;
  const auto targets = design::parseTargets("mass=0.5%,com=0.001", {});
  const auto t1 = std::chrono::steady_clock::now();
  const design::DurationSearchResult d = design::findShortestDuration(s, kin, targets);
  const double wall2 = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  for (const auto& t : d.trials) {
    std::printf("  %5.2f s  cond %9.4g  mass std %.3g %%  com std max %.3g mm  %s\n", t.duration_s,
                t.condition_number,
                t.predicted_std.count("mass")
                    ? 100 * t.predicted_std.at("mass") / sim::PaperPayload::kMass_kg
                    : std::nan(""),
                t.predicted_std.count("com_x")
                    ? 1e3 * std::max({t.predicted_std.at("com_x"), t.predicted_std.at("com_y"),
                                      t.predicted_std.at("com_z")})
                    : std::nan(""),
                t.met ? "meets" : "misses");
  }
  std::printf("search wall time %.1f s\n", wall2);
  if (d.found) {
    std::printf("shortest duration meeting the targets: %.2f s (cond %.4g)\n",
                d.best.file.duration_s, d.best.condition_number);
    // Paper model: simulate the physics it assumes (errors = noise); richer models: full physics.
    const bool full = s.model != "paper";
    const SimErrors e = simulate(kin, d.best.file.toTrajectory(), seeds, s.model, full);
    std::printf(
        "  simulated (%d seeds, %s physics): mass RMS error %.3g %%, com RMS error %.3g mm\n",
        seeds, full ? "full rigid-body" : "paper-model", 100 * e.mass_rel_rms, 1e3 * e.com_rms);
  } else {
    std::printf("no duration up to 60 s met the targets\n");
  }
  return 0;
}
