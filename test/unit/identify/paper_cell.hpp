#pragma once
// Test helper: simulated logs of the paper's cell (engineer f1's simulator, independent physics)
// turned into SampleContexts.
#include <cmath>
#include <functional>
#include <string>

#include "ftid/samples/context.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/sim/cell_sim.hpp"
#include "test_paths.hpp"

namespace ftid::test {

inline model::RobotKinematics ur10() {
  return model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/ur10.urdf"));
}

constexpr double kDegToRad = 3.141592653589793 / 180.0;

/// Paper cell with the paper's physics (full_rigid_body = false).
inline sim::CellSimConfig paperConfig(bool noisy, std::uint64_t seed) {
  sim::CellSimConfig cfg = sim::paperCellConfig(ur10());
  cfg.full_rigid_body = false;
  cfg.seed = seed;
  if (noisy) cfg.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  return cfg;
}

/// Rest poses: `poses` distinct wrist orientations, held for `per_pose` samples each (qd = qdd = 0).
inline void useRestPoses(sim::CellSimConfig& cfg, int poses, int per_pose) {
  cfg.rate_hz = 10.0;
  cfg.duration_s = (poses * per_pose - 1) / cfg.rate_hz;
  const double rate = cfg.rate_hz;
  cfg.motion = [poses, per_pose, rate](double t) {
    int k = static_cast<int>(std::floor(t * rate + 1e-9)) / per_pose;
    if (k >= poses) k = poses - 1;
    trajectory::TrajectoryPoint p;
    p.q = sim::paperStartPose();
    p.q(3) += 0.9 * std::sin(1.3 * k);
    p.q(4) += 1.1 * std::cos(0.7 * k + 0.4);
    p.q(5) += 1.5 * std::sin(2.1 * k + 1.0);
    return p;
  };
}

inline samples::ContextSet contextsOf(const sim::CellSimConfig& cfg) {
  const logio::LogData log = sim::CellSim(cfg).run();
  return samples::buildContexts(log, *cfg.robot);
}

struct Table2 {
  static double weight() { return sim::PaperPayload::kWeight_N; }
  static double mass() { return sim::PaperPayload::kMass_kg; }
  static Vec3 com() { return sim::PaperPayload::centreOfMass(); }
  static Vec3 f0() { return sim::PaperPayload::forceOffset(); }
  static Vec3 t0() { return sim::PaperPayload::torqueOffset(); }
  static double u() { return sim::PaperPayload::kTiltU_deg * kDegToRad; }
  static double v() { return sim::PaperPayload::kTiltV_deg * kDegToRad; }
  /// Truth by the JSON/parameter names.
  static double value(const std::string& name) {
    const char* ax = "xyz";
    for (int i = 0; i < 3; ++i) {
      if (name == std::string("com_") + ax[i]) return com()(i);
      if (name == std::string("f0_") + ax[i]) return f0()(i);
      if (name == std::string("t0_") + ax[i]) return t0()(i);
      if (name == std::string("mass_com_") + ax[i]) return mass() * com()(i);
    }
    if (name == "mass") return mass();
    if (name == "weight") return weight();
    if (name == "tilt_u") return u();
    if (name == "tilt_v") return v();
    throw std::out_of_range(name);
  }
};

inline const char* const kTwelve[] = {"weight", "mass", "com_x", "com_y", "com_z", "f0_x", "f0_y",
                                      "f0_z",   "t0_x", "t0_y",  "t0_z",  "tilt_u", "tilt_v"};

}  // namespace ftid::test
