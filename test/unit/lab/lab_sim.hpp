#pragma once
// Simulated cell runs for the laboratory tests: the paper's cell with a heavier payload and a
// richer excitation of all six joints, seeded noise 0.05 N / 0.01 Nm.
#include <array>
#include <string>
#include <vector>

#include "ftid/samples/context.hpp"
#include "ftid/lab/analyze.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/sim/cell_sim.hpp"
#include "ftid/sim/effect_spec.hpp"
#include "test_paths.hpp"

namespace ftid::labtest {

inline model::RobotKinematics robot() {
  return model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/ur10.urdf"));
}

/// 10 s, 0.2 Hz base, 3 harmonics on every joint, rest-to-rest.
inline trajectory::FourierTrajectory richTrajectory() {
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

inline sim::CellSimConfig baseConfig(std::uint64_t seed) {
  sim::CellSimConfig c = sim::paperCellConfig(robot());
  c.trajectory = richTrajectory();
  c.payload.mass_kg = 3.0;
  c.payload.p_SC_S = Vec3(0.02, -0.015, 0.09);
  c.payload.I_C_S << 0.030, 0.002, -0.001, 0.002, 0.040, 0.003, -0.001, 0.003, 0.020;
  c.rate_hz = 125.0;
  c.duration_s = 10.0;
  c.seed = seed;
  c.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  c.full_rigid_body = false;  // the paper model is then exact: hidden effects are switched on per test
  return c;
}

inline samples::ContextSet contexts(const sim::CellSimConfig& c) {
  const logio::LogData log = sim::CellSim(c).run();
  return samples::buildContexts(log, *c.robot, {c.R_FS, c.p_FS_F, 0.0, 0.0});
}

inline lab::AnalysisResult analyzeRun(const sim::CellSimConfig& c, const std::string& model, bool explain) {
  const samples::ContextSet set = contexts(c);
  lab::AnalyzeOptions o;
  o.model = model;
  o.explain = explain;
  return lab::analyze(set.samples, nullptr, o, "sim.csv");
}

inline const lab::ParamEstimate* findParam(const lab::ModelReport& r, const std::string& name) {
  for (const auto& p : r.params) {
    if (p.name == name) return &p;
  }
  return nullptr;
}

/// `ftid analyze LOG` of the log that `ftid simulate --seed SEED --effect EFFECT --out LOG` writes
/// (the paper's cell and 10 s excitation, the command's default noise), read back from `log`:
/// what a user reproducing a case from the command line sees.
inline lab::AnalysisResult analyzeCommandLineRun(const std::string& log, std::uint64_t seed, const std::string& effect,
                                                 bool explain) {
  sim::CellSimConfig c = sim::paperCellConfig(robot());
  c.seed = seed;
  c.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  sim::applyEffectSpec(effect, c);
  logio::writeLog(log, sim::CellSim(c).run());
  lab::AnalyzeFilesRequest req;
  req.log_path = log;
  req.robot_urdf = ftid::test::sourcePath("/config/ur10.urdf");
  req.options.explain = explain;
  return lab::analyzeRecordings(req);
}

}  // namespace ftid::labtest
