// Presets: the paper's Table 2 payload and a paper-style excitation trajectory.
#include <cmath>

#include "ftid/sim/cell_sim.hpp"

namespace ftid::sim {

PayloadTruth PaperPayload::payload() {
  PayloadTruth p;
  p.mass_kg = kMass_kg;
  p.p_SC_S = centreOfMass();
  const double r = 0.04, h = 0.10, m = kMass_kg;
  const double ixx = m * (3.0 * r * r + h * h) / 12.0;
  const double izz = m * r * r / 2.0;
  p.I_C_S = Vec3(ixx, ixx, izz).asDiagonal();
  return p;
}

void PaperPayload::apply(CellSimConfig& config) {
  config.payload = payload();
  config.F0_N = forceOffset();
  config.T0_Nm = torqueOffset();
  constexpr double kDeg = 3.141592653589793 / 180.0;
  config.tilt_u_rad = kTiltU_deg * kDeg;
  config.tilt_v_rad = kTiltV_deg * kDeg;
}

JointVector paperStartPose() {
  JointVector q0;
  q0 << 0.0, -1.57, 1.57, -1.57, -1.57, 0.0;
  return q0;
}

trajectory::FourierTrajectory paperExcitationTrajectory() {
  using Coefficients = std::array<std::array<double, trajectory::FourierTrajectory::kMaxHarmonics>, kNumJoints>;
  Coefficients a{}, b{};
  // Joints 4-6 (indices 3-5); sum_l a_l = 0 and sum_l l b_l = 0 for rest-to-rest.
  // Peak |qd| ~ 1.27 rad/s, |qdd| ~ 1.72 rad/s^2, excursions within about +-1.9 rad of q0.
  a[3] = {0.55, -0.25, -0.20, 0.05, -0.15};
  b[3] = {0.20, 0.35, -0.20, 0.05, -0.10};
  a[4] = {-0.45, 0.35, 0.10, -0.15, 0.15};
  b[4] = {0.30, -0.25, 0.10, 0.05, -0.06};
  a[5] = {0.50, -0.10, -0.30, 0.10, -0.20};
  b[5] = {-0.25, 0.20, 0.15, -0.20, 0.04};
  return trajectory::FourierTrajectory(paperStartPose(), 0.1, 5, 10.0, a, b);
}

CellSimConfig paperCellConfig(model::RobotKinematics robot) {
  CellSimConfig c;
  c.robot = std::move(robot);
  PaperPayload::apply(c);
  c.trajectory = paperExcitationTrajectory();
  c.rate_hz = 125.0;
  c.duration_s = 10.0;
  return c;
}

}  // namespace ftid::sim
