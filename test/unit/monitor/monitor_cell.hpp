#pragma once
// Test helper: a simulated cell with full rigid-body physics whose payload A is identified on the
// paper's excitation trajectory (`paper+rigid_body`), then operated on random motions (other seeds
// than the settings were chosen on) with pushes or a grasp, replayed through ftidd's compensator
// and the payload monitor.
#include <string>
#include <vector>

#include "ftid/compensate/monitor_log.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/identify/fit_parameters.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/sim/scenarios.hpp"
#include "test_paths.hpp"

namespace ftid::test {

inline model::RobotKinematics monitorRobot() {
  return model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/ur10.urdf"));
}

/// The cell with payload A (the paper's payload), full physics, the noise of `ftid simulate`.
inline sim::CellSimConfig monitorCell(std::uint64_t seed) {
  sim::CellSimConfig cfg = sim::paperCellConfig(monitorRobot());
  cfg.full_rigid_body = true;
  cfg.seed = seed;
  cfg.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  return cfg;
}

/// Payload A identified from a 10 s excitation run (noise seed `seed`).
struct IdentifiedCell {
  effects::Model model = effects::Model::fromName("paper+rigid_body");
  params::ParameterSet set;
  Eigen::VectorXd theta;
  effects::NonlinearParams nonlinear;

  explicit IdentifiedCell(std::uint64_t seed) {
    const sim::CellSimConfig cfg = monitorCell(seed);
    const logio::LogData log = sim::CellSim(cfg).run();
    const samples::ContextSet contexts = samples::buildContexts(log, *cfg.robot);
    const identify::FitResult fit = identify::fitModel(model, contexts.samples);
    set = identify::toParameterSet(fit);
    theta = params::thetaFor(model, set);
    nonlinear = params::nonlinearFor(model, set);
  }
};

/// An operation run: random motion `motion_seed`, `duration_s`, noise seed `seed`.
inline sim::CellSimConfig operationRun(std::uint64_t seed, std::uint64_t motion_seed, double duration_s) {
  sim::CellSimConfig cfg = monitorCell(seed);
  const trajectory::FourierTrajectory motion = sim::randomOperationTrajectory(motion_seed);
  const double period = motion.duration();
  cfg.motion = [motion, period](double t) { return motion.evaluate(std::fmod(t, period)); };
  cfg.duration_s = duration_s;
  return cfg;
}

/// Replays the run through the identified compensator and a monitor with `settings`.
inline compensate::MonitorReplay replayRun(const IdentifiedCell& cell, const sim::CellSimConfig& cfg,
                                           const monitor::MonitorSettings& settings = {}) {
  const logio::LogData log = sim::CellSim(cfg).run();
  samples::ContextSet contexts = samples::buildContexts(log, *cfg.robot);
  samples::setTilt(contexts.samples, cell.nonlinear.tilt_u_rad, cell.nonlinear.tilt_v_rad);
  compensate::Compensator comp(cell.model, cell.theta, cell.nonlinear);
  monitor::PayloadMonitor mon(settings);
  return compensate::replayMonitor(contexts.samples, comp, mon);
}

/// The monitor samples of a run (compensated with payload A), in time order.
inline std::vector<monitor::MonitorSample> monitorSamples(const IdentifiedCell& cell, const sim::CellSimConfig& cfg) {
  const logio::LogData log = sim::CellSim(cfg).run();
  samples::ContextSet contexts = samples::buildContexts(log, *cfg.robot);
  samples::setTilt(contexts.samples, cell.nonlinear.tilt_u_rad, cell.nonlinear.tilt_v_rad);
  compensate::Compensator comp(cell.model, cell.theta, cell.nonlinear);
  std::vector<monitor::MonitorSample> out;
  for (const auto& ctx : contexts.samples) {
    Wrench contact;
    if (comp.compute(ctx, &contact, nullptr) == Status::kOk) out.push_back(compensate::monitorSample(ctx, contact));
  }
  return out;
}

/// [m, m c, I_S] of the identified payload A.
inline monitor::ChangeVector payloadOf(const IdentifiedCell& cell) {
  static constexpr const char* kNames[monitor::kChangeParams] = {
      "mass", "mass_com_x", "mass_com_y", "mass_com_z", "i_s_xx", "i_s_yy", "i_s_zz", "i_s_xy", "i_s_xz", "i_s_yz"};
  monitor::ChangeVector p;
  for (int j = 0; j < monitor::kChangeParams; ++j) p[j] = cell.theta[cell.model.paramIndex().column(kNames[j])];
  return p;
}

}  // namespace ftid::test
