// Payload monitor figures (docs/performance.md, "Payload monitor"), offline and faster than real
// time: the residual floor with identified parameters, the false alarms over simulated operation
// with random pushes, and the detection latency of 0.1, 0.3 and 1 kg grasps.
//   bench_monitor [minutes]      (default 30 minutes of operation with pushes)
// Payload A is identified on the excitation trajectory (`paper+rigid_body`, full physics, the
// noise of `ftid simulate`); operation is random wrist motion (sim::randomOperationTrajectory)
// with 12 N pushes of 0.4-0.6 s every 1-6 s, seeds 50000+ (the tests use 1000-4000).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "ftid/common/default_files.hpp"
#include "ftid/compensate/monitor_log.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/identify/fit_parameters.hpp"
#include "ftid/sim/scenarios.hpp"

namespace {

using namespace ftid;

sim::CellSimConfig cellConfig(const model::RobotKinematics& kin, std::uint64_t seed) {
  sim::CellSimConfig cfg = sim::paperCellConfig(kin);
  cfg.full_rigid_body = true;
  cfg.seed = seed;
  cfg.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  return cfg;
}

struct Cell {
  effects::Model model = effects::Model::fromName("paper+rigid_body");
  Eigen::VectorXd theta;
  effects::NonlinearParams nonlinear;
};

sim::CellSimConfig operation(const model::RobotKinematics& kin, std::uint64_t seed, double duration_s) {
  sim::CellSimConfig cfg = cellConfig(kin, seed);
  const trajectory::FourierTrajectory motion = sim::randomOperationTrajectory(seed + 1);
  const double period = motion.duration();
  cfg.motion = [motion, period](double t) { return motion.evaluate(std::fmod(t, period)); };
  cfg.duration_s = duration_s;
  return cfg;
}

struct Run {
  compensate::MonitorReplay replay;
  Vec6 residual_rms = Vec6::Zero();
};

Run replay(const Cell& cell, const sim::CellSimConfig& cfg) {
  const logio::LogData log = sim::CellSim(cfg).run();
  samples::ContextSet contexts = samples::buildContexts(log, *cfg.robot);
  samples::setTilt(contexts.samples, cell.nonlinear.tilt_u_rad, cell.nonlinear.tilt_v_rad);
  compensate::Compensator comp(cell.model, cell.theta, cell.nonlinear);
  monitor::PayloadMonitor mon{monitor::MonitorSettings{}};
  Run run;
  run.replay = compensate::replayMonitor(contexts.samples, comp, mon);
  compensate::Compensator comp2(cell.model, cell.theta, cell.nonlinear);
  int n = 0;
  for (const auto& ctx : contexts.samples) {
    Wrench c;
    if (comp2.compute(ctx, &c, nullptr) != Status::kOk) continue;
    run.residual_rms += c.cwiseAbs2();
    ++n;
  }
  if (n > 0) run.residual_rms = (run.residual_rms / n).cwiseSqrt();
  return run;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::min<double>(v.size() - 1, std::floor(p * (v.size() - 1) + 0.5)))];
}

}  // namespace

int main(int argc, char** argv) {
  const double minutes = argc > 1 ? std::atof(argv[1]) : 30.0;
  const auto kin = model::RobotKinematics::fromUrdfFile(defaultRobotUrdf());
  Cell cell;
  {
    const logio::LogData log = sim::CellSim(cellConfig(kin, 49999)).run();
    const samples::ContextSet contexts = samples::buildContexts(log, kin);
    const identify::FitResult fit = identify::fitModel(cell.model, contexts.samples);
    const params::ParameterSet set = identify::toParameterSet(fit);
    cell.theta = params::thetaFor(cell.model, set);
    cell.nonlinear = params::nonlinearFor(cell.model, set);
  }

  // 1. Residual floor on clean operation (the noise_std default).
  {
    Vec6 worst = Vec6::Zero();
    for (std::uint64_t seed = 50001; seed <= 50010; ++seed) {
      worst = worst.cwiseMax(replay(cell, operation(kin, seed, 60.0)).residual_rms);
    }
    std::printf("residual RMS, clean operation (worst of 10 runs of 60 s): fx %.3f fy %.3f fz %.3f N  tx %.4f ty %.4f tz %.4f Nm\n",
                worst[0], worst[1], worst[2], worst[3], worst[4], worst[5]);
  }

  // 2. False alarms over `minutes` of operation with pushes.
  {
    const double run_s = 60.0;
    const int runs = static_cast<int>(std::ceil(minutes));
    int pushes = 0, contacts = 0, false_changes = 0, missed = 0;
    for (int k = 0; k < runs; ++k) {
      const std::uint64_t seed = 51000 + static_cast<std::uint64_t>(k);
      sim::CellSimConfig cfg = operation(kin, seed, run_s);
      cfg.pushes = sim::randomPushes(seed, 0.0, run_s);
      const Run r = replay(cell, cfg);
      pushes += static_cast<int>(cfg.pushes.size());
      for (const auto& e : r.replay.events) {
        if (e.kind == monitor::EventKind::kPayloadChange) {
          ++false_changes;
          std::printf("  false payload change: seed %llu t %.3f dm %.3f\n", static_cast<unsigned long long>(seed),
                      e.t_decided, e.change.delta_mass_kg);
        } else {
          ++contacts;
        }
      }
      for (const auto& p : cfg.pushes) {
        bool seen = false;
        for (const auto& e : r.replay.events) seen |= e.t_onset >= p.t_start_s - 0.05 && e.t_onset <= p.t_end_s;
        missed += seen ? 0 : 1;
      }
    }
    std::printf("operation with pushes: %d min, %d pushes of 12 N (0.4-0.6 s): %d payload-change false alarms, "
                "%d contact events, %d pushes without an event\n",
                runs, pushes, false_changes, contacts, missed);
  }

  // 3. Detection latency of grasps at t = 5 s.
  for (const double mass : {0.1, 0.3, 0.6, 1.0}) {
    std::vector<double> latency, error;
    int misses = 0;
    const int trials = 30;
    for (int k = 0; k < trials; ++k) {
      const std::uint64_t seed = 60000 + static_cast<std::uint64_t>(k) + static_cast<std::uint64_t>(mass * 1000) * 100;
      sim::CellSimConfig cfg = operation(kin, seed, 8.0);
      cfg.payload_change.enabled = true;
      cfg.payload_change.t_s = 5.0;
      const double a = 0.7 * static_cast<double>(k);
      cfg.payload_change.added = sim::compactObject(mass, Vec3(0.03 * std::cos(a), 0.03 * std::sin(a), 0.08 + 0.002 * k));
      const Run r = replay(cell, cfg);
      bool found = false;
      for (const auto& e : r.replay.events) {
        if (e.kind != monitor::EventKind::kPayloadChange || found) continue;
        found = true;
        latency.push_back(e.t_decided - 5.0);
        error.push_back(e.change.delta_mass_kg / mass - 1.0);
      }
      misses += found ? 0 : 1;
    }
    double worst_err = 0.0;
    for (double e : error) worst_err = std::max(worst_err, std::abs(e));
    std::printf("grasp %.1f kg (%d runs): missed %d, latency median %.3f s, p90 %.3f s, max %.3f s; mass error at the "
                "decision: worst %.1f %%\n",
                mass, trials, misses, percentile(latency, 0.5), percentile(latency, 0.9), percentile(latency, 1.0),
                100.0 * worst_err);
  }
  return 0;
}
