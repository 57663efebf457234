// Benchmark of the model laboratory: the equivalent of `ftid analyze LOG --explain` on 10 s of
// data at 1 kHz (10,001 samples, 60,006 regressor rows) with every candidate effect (all named
// effects plus the default generic menu). The run hides two effects (rigid_body and
// temperature_drift), so the explain path takes two steps and ranks the candidates three times.
// A second case repeats it as a real sensor streams it: low-pass filtered noise and 0.4 % glitches
// (noise colour from the residual, prewhitened fits, glitches left out and re-fitted).
// Figures: docs/performance.md, section "Model laboratory".
#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "ftid/common/default_files.hpp"
#include "ftid/samples/context.hpp"
#include "ftid/identify/offline.hpp"
#include "ftid/lab/analyze.hpp"
#include "ftid/sim/cell_sim.hpp"

namespace {

using namespace ftid;

trajectory::FourierTrajectory richTrajectory() {
  using C = std::array<std::array<double, trajectory::FourierTrajectory::kMaxHarmonics>, kNumJoints>;
  C a{}, b{};
  a[0] = {0.30, -0.10, 0.15};
  b[0] = {0.10, 0.20, -0.05};
  a[1] = {-0.25, 0.15, 0.10};
  b[1] = {0.15, -0.10, 0.10};
  a[2] = {0.30, 0.10, -0.15};
  b[2] = {-0.20, 0.15, 0.05};
  a[3] = {0.45, -0.25, 0.20};
  b[3] = {0.20, 0.30, -0.20};
  a[4] = {-0.40, 0.30, 0.25};
  b[4] = {0.30, -0.25, 0.15};
  a[5] = {0.50, -0.30, 0.35};
  b[5] = {-0.25, 0.20, 0.30};
  // Rest-to-rest (sum_l a_l = 0, sum_l l b_l = 0): the third harmonic closes each joint.
  for (int j = 0; j < kNumJoints; ++j) {
    a[j][2] = -(a[j][0] + a[j][1]);
    b[j][2] = -(b[j][0] + 2.0 * b[j][1]) / 3.0;
  }
  return trajectory::FourierTrajectory(sim::paperStartPose(), 0.2, 3, 10.0, a, b);
}

double now() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace

int main(int argc, char** argv) {
  const int reps = argc > 1 ? std::max(1, std::atoi(argv[1])) : 3;
  sim::CellSimConfig cfg =
      sim::paperCellConfig(model::RobotKinematics::fromUrdfFile(defaultRobotUrdf()));
  cfg.trajectory = richTrajectory();
  cfg.payload.mass_kg = 3.0;
  cfg.payload.p_SC_S = Vec3(0.02, -0.015, 0.09);
  cfg.payload.I_C_S << 0.030, 0.002, -0.001, 0.002, 0.040, 0.003, -0.001, 0.003, 0.020;
  cfg.rate_hz = 1000.0;
  cfg.duration_s = 10.0;
  cfg.seed = 5;
  cfg.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  cfg.full_rigid_body = true;
  cfg.temperature_drift.enabled = true;
  auto runCase = [&](const char* label, const sim::CellSimConfig& c) {
    double t0 = now();
    const logio::LogData log = sim::CellSim(c).run();
    const double t_sim = now() - t0;
    t0 = now();
    const samples::ContextSet set = samples::buildContexts(log, *c.robot);
    const double t_ctx = now() - t0;
    std::printf("bench_analyze [%s]: %zu samples (10 s at 1 kHz); simulate %.3f s, contexts %.3f s\n", label, set.size(),
                t_sim, t_ctx);
    lab::AnalyzeOptions o;
    o.model = "paper";
    o.explain = true;
    std::vector<double> times;
    lab::AnalysisResult r;
    for (int k = 0; k < reps; ++k) {
      t0 = now();
      r = lab::analyze(set.samples, nullptr, o, "bench.csv");
      times.push_back(now() - t0);
    }
    std::sort(times.begin(), times.end());
    int ranked = 0;
    for (const auto& cand : r.candidates) ranked += cand.skipped ? 0 : 1;
    std::printf("analyze --explain (5-fold, %d candidates per ranking, %zu steps, noise %s, %d glitches): min %.3f s, "
                "median %.3f s over %d runs\n",
                ranked, r.steps.size(), r.noise_method.c_str(), r.outliers.count, times.front(), times[times.size() / 2],
                reps);
    for (std::size_t k = 0; k < r.steps.size(); ++k) {
      std::printf("  step %zu %-45s x noise %.3f\n", k, r.steps[k].model.c_str(), r.steps[k].total_ratio);
    }
  };
  runCase("white noise", cfg);
  // The same run as a real sensor streams it: noise low-pass filtered at 40 Hz, 0.4 % glitches.
  sim::CellSimConfig real = cfg;
  real.noise.wrench_lowpass_hz = 40.0;
  real.glitches.enabled = true;
  runCase("filtered noise + glitches", real);
  return 0;
}
