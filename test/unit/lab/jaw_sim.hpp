#pragma once
// A 0.3 kg gripper jaw moving along the tool's x axis with a logged column `grip`, added to a
// simulator run with its own physics (not ftid's regressor): a point mass at its momentary
// position c = p0 + grip(t) d, Newton's law for the acceleration of that point (the tool's motion
// and the jaw's own along d) and its moment about S. Kinematics from the simulator: R_BS, w, alpha,
// a_S of the sensor at the trajectory's state, gravity from its noise-free IMU (a_S - specific
// force). Used by the laboratory's and the compensation's tests.
#include <cmath>
#include <vector>

#include "ftid/logio/log.hpp"
#include "ftid/sim/cell_sim.hpp"

namespace ftid::jawtest {

constexpr double kPi = 3.141592653589793;
constexpr double kJawMass = 0.3;          ///< [kg]
inline const Vec3 kJawStart(0.0, 0.03, 0.10);  ///< p0 [m], in S
inline const Vec3 kJawTravel(0.04, 0.0, 0.0);  ///< d [m]: the jaw at p0 + grip d
constexpr double kGripPeriod = 5.0;       ///< [s]: grip = (1 - cos(2 pi t / T)) / 2, 0..1

inline double grip(double t) { return 0.5 * (1.0 - std::cos(2.0 * kPi * t / kGripPeriod)); }

/// The jaw's force and moment on the sensor at time t (S frame, N and Nm).
inline Vec6 jawWrench(const sim::CellSim& s, double t) {
  const auto state = s.stateAt(t);
  const model::SensorMotion m = s.config().robot->computeSensorMotion(state.q, state.qd, state.qdd);
  const Vec3 g_S = m.a_S - s.sampleAt(t).acc_S;
  const double w0 = 2.0 * kPi / kGripPeriod;
  const Vec3 c = kJawStart + grip(t) * kJawTravel;
  const Vec3 c_dot = 0.5 * w0 * std::sin(w0 * t) * kJawTravel;
  const Vec3 c_ddot = 0.5 * w0 * w0 * std::cos(w0 * t) * kJawTravel;
  const Vec3 a_jaw = m.a_S + m.alpha_S.cross(c) + m.w_S.cross(m.w_S.cross(c)) + 2.0 * m.w_S.cross(c_dot) + c_ddot;
  const Vec3 f = kJawMass * (g_S - a_jaw);
  Vec6 w;
  w << f, c.cross(f);
  return w;
}

/// Adds the jaw's wrench to every reading of `log` (a run of `s`) and the column `grip`.
inline void addJaw(const sim::CellSim& s, logio::LogData& log) {
  std::vector<double> column;
  for (auto& sample : log.samples) {
    sample.wrench_S += jawWrench(s, sample.t);
    column.push_back(grip(sample.t));
  }
  log.extra_names.emplace_back("grip");
  log.extra_columns.push_back(column);
}

}  // namespace ftid::jawtest
