// The sensor imperfections of the simulator (docs/simulator.md), each checked against its
// documented model computed here in another way: coloured noise against the AR(1) statistics of a
// 1st-order low-pass, oversampling against the 1/sqrt(K) law, glitches against the difference of
// two runs, a mounting rotation against rotation matrices written out element by element, a
// negative delay against the undelayed run, and static pose sets against the moving run.
#include <cmath>
#include <string>

#include <gtest/gtest.h>

#include "ftid/common/error.hpp"
#include "ftid/sim/cell_sim.hpp"
#include "test_paths.hpp"

namespace ftid::sim {
namespace {

constexpr double kPi = 3.141592653589793;

CellSimConfig config() {
  CellSimConfig c = paperCellConfig(model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/ur10.urdf")));
  c.seed = 17;
  c.duration_s = 20.0;
  return c;
}

/// Noise of a run = its wrench minus the same configuration's noise-free wrench.
std::vector<Wrench> noiseOf(CellSimConfig c) {
  const logio::LogData noisy = CellSim(c).run();
  c.noise.wrench_std.setZero();
  const logio::LogData clean = CellSim(c).run();
  std::vector<Wrench> out;
  for (std::size_t k = 0; k < noisy.samples.size(); ++k) out.push_back(noisy.samples[k].wrench_S - clean.samples[k].wrench_S);
  return out;
}

double stdOf(const std::vector<Wrench>& x, int a) {
  double m = 0.0, s = 0.0;
  for (const auto& w : x) m += w(a) / static_cast<double>(x.size());
  for (const auto& w : x) s += (w(a) - m) * (w(a) - m);
  return std::sqrt(s / static_cast<double>(x.size() - 1));
}

double lagCorrelation(const std::vector<Wrench>& x, int a, int lag) {
  double m = 0.0;
  for (const auto& w : x) m += w(a) / static_cast<double>(x.size());
  double c0 = 0.0, cl = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    c0 += (x[i](a) - m) * (x[i](a) - m);
    if (i >= static_cast<std::size_t>(lag)) cl += (x[i](a) - m) * (x[i - static_cast<std::size_t>(lag)](a) - m);
  }
  return cl / c0;
}

TEST(Imperfections, LowPassNoiseHasTheStdAndCorrelationOfAFirstOrderFilter) {
  CellSimConfig c = config();
  c.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  c.noise.wrench_lowpass_hz = 10.0;
  const auto n = noiseOf(c);
  // 1st-order low-pass sampled at 125 Hz: lag-l correlation exp(-2 pi fc l / rate).
  const double phi = std::exp(-2.0 * kPi * 10.0 / 125.0);
  double r1 = 0.0, r3 = 0.0;
  for (int a = 0; a < 6; ++a) {
    EXPECT_NEAR(stdOf(n, a), c.noise.wrench_std(a), 0.12 * c.noise.wrench_std(a)) << a;
    r1 += lagCorrelation(n, a, 1) / 6.0;
    r3 += lagCorrelation(n, a, 3) / 6.0;
  }
  // Averaged over the six independent axes (each scatters by about 0.03 over 2,501 samples).
  EXPECT_NEAR(r1, phi, 0.03);
  EXPECT_NEAR(r3, phi * phi * phi, 0.04);
}

TEST(Imperfections, OversampledNoiseIsAveragedAndStaysWhite) {
  CellSimConfig c = config();
  c.noise.wrench_std << 0.08, 0.08, 0.08, 0.02, 0.02, 0.02;
  c.noise.wrench_oversample = 4;
  const auto n = noiseOf(c);
  for (int a = 0; a < 6; ++a) {
    EXPECT_NEAR(stdOf(n, a), c.noise.wrench_std(a) / 2.0, 0.06 * c.noise.wrench_std(a)) << a;
    EXPECT_NEAR(lagCorrelation(n, a, 1), 0.0, 0.07) << a;
  }
  // The signal is averaged over the K sub-samples centred on t: equal to the mean of sampleAt.
  c.noise.wrench_std.setZero();
  const CellSim sim(c);
  const logio::LogData log = sim.run();
  CellSimConfig c1 = c;
  c1.noise.wrench_oversample = 1;
  const CellSim one(c1);
  for (std::size_t k : {std::size_t{100}, std::size_t{777}}) {
    const double t = log.samples[k].t;
    Wrench mean = Wrench::Zero();
    for (double off : {-1.5, -0.5, 0.5, 1.5}) mean += one.sampleAt(t + off / (4.0 * c.rate_hz)).wrench_S / 4.0;
    EXPECT_LT((log.samples[k].wrench_S - mean).norm(), 1e-12);
  }
}

TEST(Imperfections, GlitchesAreIsolatedSpikesAndChangeNothingElse) {
  CellSimConfig c = config();
  c.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  const logio::LogData clean = CellSim(c).run();
  c.glitches.enabled = true;
  c.glitches.probability = 0.01;
  const CellSim sim(c);
  const logio::LogData hit = sim.run();
  const std::vector<Glitch> g = sim.glitches();
  ASSERT_EQ(clean.samples.size(), hit.samples.size());
  const double n = static_cast<double>(hit.samples.size());
  EXPECT_NEAR(static_cast<double>(g.size()), 0.01 * n, 4.0 * std::sqrt(0.01 * n));
  std::size_t next = 0;
  for (std::size_t k = 0; k < hit.samples.size(); ++k) {
    Wrench expected = clean.samples[k].wrench_S;
    while (next < g.size() && g[next].sample == k) {
      EXPECT_DOUBLE_EQ(std::abs(g[next].value), g[next].axis < 3 ? 10.0 : 1.0);
      expected(g[next].axis) += g[next].value;
      ++next;
    }
    ASSERT_LT((hit.samples[k].wrench_S - expected).norm(), 1e-12) << k;  // noise unchanged
    ASSERT_EQ(hit.samples[k].acc_S, clean.samples[k].acc_S);
  }
}

TEST(Imperfections, MountingRotationReportsTheWrenchInTheTrueFrame) {
  CellSimConfig c = config();
  c.crosstalk.enabled = false;
  const CellSim straight(c);
  c.mounting.enabled = true;
  c.mounting.rpy_rad = Vec3(0.02, -0.03, 0.07);
  const CellSim rotated(c);
  // R_SS' = Rz(y) Ry(p) Rx(r), written out.
  const double r = 0.02, p = -0.03, y = 0.07;
  Mat3 Rx, Ry, Rz;
  Rx << 1, 0, 0, 0, std::cos(r), -std::sin(r), 0, std::sin(r), std::cos(r);
  Ry << std::cos(p), 0, std::sin(p), 0, 1, 0, -std::sin(p), 0, std::cos(p);
  Rz << std::cos(y), -std::sin(y), 0, std::sin(y), std::cos(y), 0, 0, 0, 1;
  const Mat3 R = Rz * Ry * Rx;
  for (double t : {0.7, 4.2, 8.9}) {
    const SensorReading a = straight.sampleAt(t);
    const SensorReading b = rotated.sampleAt(t);
    const Wrench o = straight.offsetsAt(t, straight.temperatureAt(t));
    const Wrench load = a.wrench_S - o;
    EXPECT_LT((b.wrench_S.head<3>() - (R.transpose() * load.head<3>() + o.head<3>())).norm(), 1e-12);
    EXPECT_LT((b.wrench_S.tail<3>() - (R.transpose() * load.tail<3>() + o.tail<3>())).norm(), 1e-12);
    EXPECT_LT((b.acc_S - R.transpose() * a.acc_S).norm(), 1e-12);  // the IMU sits in the sensor
    // The magnitude of the force is unchanged; its direction is not.
    EXPECT_NEAR(load.head<3>().norm(), (b.wrench_S - o).head<3>().norm(), 1e-12);
    EXPECT_GT((b.wrench_S - a.wrench_S).norm(), 0.05);
  }
}

TEST(Imperfections, NegativeDelayMakesTheWrenchLead) {
  CellSimConfig c = config();
  const CellSim off(c);
  c.sensor_delay.enabled = true;
  c.sensor_delay.tau_s = -0.021;
  const CellSim lead(c);
  for (double t : {1.0, 3.3}) EXPECT_LT((lead.sampleAt(t).wrench_S - off.sampleAt(t + 0.021).wrench_S).norm(), 1e-12);
  c.sensor_delay.tau_s = -1.5;
  EXPECT_THROW(CellSim{c}, ConfigError);
}

TEST(Imperfections, StaticPoseSetsHoldPosesAndAverageThem) {
  CellSimConfig c = config();
  c.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  c.static_poses.enabled = true;
  c.static_poses.poses = 12;
  c.static_poses.hold_s = 0.2;  // 25 samples a pose
  const logio::LogData held = CellSim(c).run();
  ASSERT_EQ(held.samples.size(), 12u * 25u);
  const trajectory::FourierTrajectory traj = paperExcitationTrajectory();
  for (int k = 0; k < 12; ++k) {
    const JointVector q = traj.evaluate((k + 0.5) * traj.duration() / 12).q;
    for (int j = 0; j < 25; ++j) {
      const auto& s = held.samples[static_cast<std::size_t>(25 * k + j)];
      ASSERT_EQ(s.q, q);
      ASSERT_EQ(s.qd.norm() + s.qdd.norm(), 0.0);
      ASSERT_NEAR(s.t, (25 * k + j) / 125.0, 1e-12);
    }
  }
  c.static_poses.average = true;
  const logio::LogData avg = CellSim(c).run();
  ASSERT_EQ(avg.samples.size(), 12u);
  for (int k = 0; k < 12; ++k) {
    Wrench mean = Wrench::Zero();
    double t = 0.0;
    for (int j = 0; j < 25; ++j) {
      mean += held.samples[static_cast<std::size_t>(25 * k + j)].wrench_S / 25.0;
      t += held.samples[static_cast<std::size_t>(25 * k + j)].t / 25.0;
    }
    EXPECT_LT((avg.samples[static_cast<std::size_t>(k)].wrench_S - mean).norm(), 1e-12);
    EXPECT_NEAR(avg.samples[static_cast<std::size_t>(k)].t, t, 1e-12);
  }
  // At rest the reading is gravity and offsets only (static formula, no motion terms).
  c.static_poses.average = false;
  c.noise.wrench_std.setZero();
  const CellSim sim(c);
  const SensorReading r = sim.sampleAt(0.1);
  EXPECT_LT((r.acc_S.norm() - 9.80665), 1e-9);
}

TEST(Imperfections, InvalidSettingsNameTheField) {
  CellSimConfig c = config();
  c.noise.wrench_oversample = 0;
  try {
    CellSim s(c);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("wrench_oversample"), std::string::npos);
  }
  c = config();
  c.noise.wrench_lowpass_hz = -1.0;
  EXPECT_THROW(CellSim{c}, ConfigError);
  c = config();
  c.glitches.probability = 2.0;
  EXPECT_THROW(CellSim{c}, ConfigError);
  c = config();
  c.static_poses.enabled = true;
  c.static_poses.hold_s = 0.0;
  EXPECT_THROW(CellSim{c}, ConfigError);
}

}  // namespace
}  // namespace ftid::sim
