// The simulator's Newton-Euler wrench is checked against formulations written here: the static
// formula, and momentum rates of change by finite differences of FK poses (f = m g - d/dt(m v_C),
// t = c x f - dH_C/dt). Every switch is checked against its documented model.
#include <cmath>
#include <random>
#include <string>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include "ftid/common/error.hpp"
#include "ftid/sim/cell_sim.hpp"
#include "test_paths.hpp"

namespace ftid::sim {
namespace {

constexpr double kPi = 3.141592653589793;

model::RobotKinematics ur10() {
  return model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/ur10.urdf"));
}

Vec3 gravityB(double u, double v) {
  const Mat3 R_WB = (Eigen::AngleAxisd(u, Vec3::UnitX()) * Eigen::AngleAxisd(v, Vec3::UnitY())).toRotationMatrix();
  return R_WB.transpose() * Vec3(0, 0, -9.80665);
}

// A payload with a general (non-diagonal) inertia tensor.
PayloadTruth generalPayload() {
  PayloadTruth p;
  p.mass_kg = 1.7;
  p.p_SC_S = Vec3(0.012, -0.021, 0.064);
  const Mat3 R = Eigen::AngleAxisd(0.6, Vec3(1, -2, 0.5).normalized()).toRotationMatrix();
  p.I_C_S = R * Vec3(0.004, 0.006, 0.0085).asDiagonal() * R.transpose();
  return p;
}

CellSimConfig baseConfig() {
  CellSimConfig c = paperCellConfig(ur10());
  c.payload = generalPayload();
  c.seed = 42;
  // A non-trivial sensor mount.
  c.R_FS = Eigen::AngleAxisd(0.5, Vec3::UnitZ()).toRotationMatrix();
  c.p_FS_F = Vec3(0.0, 0.0, 0.035);
  return c;
}

// A trajectory moving every joint (analytic derivatives), used through the `motion` provider.
trajectory::TrajectoryPoint allJointsMotion(double t) {
  trajectory::TrajectoryPoint p;
  const double amp[6] = {0.5, 0.4, 0.6, 1.0, 0.9, 1.2};
  const double w[6] = {0.9, 1.3, 1.7, 2.1, 2.6, 3.1};
  const double c[6] = {0.1, -1.5, 1.4, -1.3, -1.6, 0.2};
  for (int i = 0; i < 6; ++i) {
    p.q[i] = c[i] + amp[i] * std::sin(w[i] * t);
    p.qd[i] = amp[i] * w[i] * std::cos(w[i] * t);
    p.qdd[i] = -amp[i] * w[i] * w[i] * std::sin(w[i] * t);
  }
  return p;
}

Vec3 vee(const Mat3& W) { return 0.5 * Vec3(W(2, 1) - W(1, 2), W(0, 2) - W(2, 0), W(1, 0) - W(0, 1)); }

TEST(CellSim, AtRestReadsGravityAndOffsets) {
  CellSimConfig c = baseConfig();
  PaperPayload::apply(c);  // paper payload, offsets and tilt
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> U(-kPi, kPi);
  const model::RobotKinematics kin = ur10();
  for (int trial = 0; trial < 20; ++trial) {
    JointVector q;
    for (int i = 0; i < 6; ++i) q[i] = U(rng);
    c.motion = [q](double) {
      trajectory::TrajectoryPoint p;
      p.q = q;
      return p;
    };
    const CellSim sim(c);
    const SensorReading r = sim.sampleAt(1.0);
    const Mat3 R_BS = kin.computeFlangePose(q).linear() * c.R_FS;
    const Vec3 g_S = R_BS.transpose() * gravityB(c.tilt_u_rad, c.tilt_v_rad);
    const double m = PaperPayload::kWeight_N / 9.80665;
    const Vec3 f = m * g_S + PaperPayload::forceOffset();
    const Vec3 t = PaperPayload::centreOfMass().cross(m * g_S) + PaperPayload::torqueOffset();
    EXPECT_LT((r.wrench_S.head<3>() - f).norm(), 1e-12);
    EXPECT_LT((r.wrench_S.tail<3>() - t).norm(), 1e-12);
    EXPECT_NEAR(r.wrench_S.head<3>().norm() > 0 ? (r.wrench_S.head<3>() - PaperPayload::forceOffset()).norm() : 0.0,
                PaperPayload::kWeight_N, 1e-9);
    EXPECT_LT((r.acc_S + g_S).norm(), 1e-12);  // accelerometer reads -g at rest
    EXPECT_LT(r.w_S.norm() + r.alpha_S.norm(), 1e-15);
  }
}

struct FdDynamics {
  const model::RobotKinematics& kin;
  const PayloadTruth& p;
  Eigen::Isometry3d pose(double t) const { return kin.computeSensorPose(allJointsMotion(t).q); }
  Vec3 comB(double t) const {
    const auto X = pose(t);
    return X.translation() + X.linear() * p.p_SC_S;
  }
  Vec3 omegaB(double t) const {
    const double h = 1e-5;
    const Mat3 Rd = (pose(t + h).linear() - pose(t - h).linear()) / (2 * h);
    return vee(Rd * pose(t).linear().transpose());
  }
  Vec3 angularMomentumB(double t) const {  // H_C = R I_C R^T w, about the centre of mass, in B
    const Mat3 R = pose(t).linear();
    return R * p.I_C_S * R.transpose() * omegaB(t);
  }
};

TEST(CellSim, NewtonEulerMatchesMomentumRatesByFiniteDifferences) {
  CellSimConfig c = baseConfig();
  c.motion = allJointsMotion;
  c.tilt_u_rad = 0.05;
  c.tilt_v_rad = -0.03;
  const CellSim sim(c);
  model::RobotKinematics kin = ur10();
  kin.setSensorMount(c.R_FS, c.p_FS_F);
  const FdDynamics fd{kin, c.payload};
  const Vec3 g_B = gravityB(c.tilt_u_rad, c.tilt_v_rad);
  const double m = c.payload.mass_kg;
  for (double t : {0.3, 1.1, 2.45, 3.8}) {
    const double h = 2.5e-4;
    const Vec3 a_C = (fd.comB(t + h) - 2 * fd.comB(t) + fd.comB(t - h)) / (h * h);
    const Vec3 dH = (fd.angularMomentumB(t + h) - fd.angularMomentumB(t - h)) / (2 * h);
    const Mat3 R = fd.pose(t).linear();
    const Vec3 c_B = R * c.payload.p_SC_S;
    // Payload on sensor: f = m g - d/dt(m v_C); moment about S: c x f - dH_C/dt.
    const Vec3 f_B = m * g_B - m * a_C;
    const Vec3 t_B = c_B.cross(f_B) - dH;
    const SensorReading r = sim.sampleAt(t);
    const Wrench load = r.wrench_S - sim.offsetsAt(t, r.temp_degC);
    EXPECT_LT((load.head<3>() - R.transpose() * f_B).norm(), 2e-6) << "t=" << t;
    EXPECT_LT((load.tail<3>() - R.transpose() * t_B).norm(), 2e-6) << "t=" << t;
    // The rotational terms are not negligible here, so the check has teeth.
    EXPECT_GT(dH.norm(), 1e-3);
    // IMU: specific force from FD of the S origin.
    const Vec3 a_S = (fd.pose(t + h).translation() - 2 * fd.pose(t).translation() + fd.pose(t - h).translation()) / (h * h);
    EXPECT_LT((r.acc_S - R.transpose() * (a_S - g_B)).norm(), 2e-4);
    EXPECT_LT((r.w_S - R.transpose() * fd.omegaB(t)).norm(), 1e-7);
  }
}

TEST(CellSim, PaperModelSwitchDropsRotationalTerms) {
  CellSimConfig c = baseConfig();
  c.motion = allJointsMotion;
  c.full_rigid_body = false;
  const CellSim paper(c);
  c.full_rigid_body = true;
  const CellSim full(c);
  model::RobotKinematics kin = ur10();
  kin.setSensorMount(c.R_FS, c.p_FS_F);
  const FdDynamics fd{kin, c.payload};
  const Vec3 g_B = gravityB(c.tilt_u_rad, c.tilt_v_rad);
  const double t = 1.7, h = 2.5e-4;
  const Mat3 R = fd.pose(t).linear();
  const Vec3 a_S = (fd.pose(t + h).translation() - 2 * fd.pose(t).translation() + fd.pose(t - h).translation()) / (h * h);
  const Vec3 f_S = R.transpose() * (c.payload.mass_kg * (g_B - a_S));
  const Wrench w = paper.sampleAt(t).wrench_S - paper.offsetsAt(t, 0.0);
  EXPECT_LT((w.head<3>() - f_S).norm(), 2e-6);
  EXPECT_LT((w.tail<3>() - c.payload.p_SC_S.cross(f_S)).norm(), 2e-6);
  EXPECT_GT((full.sampleAt(t).wrench_S - paper.sampleAt(t).wrench_S).norm(), 1e-3);
}

TEST(CellSim, CableAddsSpringWrench) {
  CellSimConfig c = baseConfig();
  const CellSim off(c);
  c.cable.enabled = true;
  c.cable.stiffness_N_per_m = 4.0;
  const CellSim on(c);
  model::RobotKinematics kin = ur10();
  kin.setSensorMount(c.R_FS, c.p_FS_F);
  for (double t : {0.0, 2.2, 6.1}) {
    const auto X = kin.computeSensorPose(off.stateAt(t).q);
    const Vec3 attach_B = X * c.cable.p_SA_S;
    const Vec3 F_S = X.linear().transpose() * (4.0 * (c.cable.p_BA_B - attach_B));
    const Wrench d = on.sampleAt(t).wrench_S - off.sampleAt(t).wrench_S;
    EXPECT_LT((d.head<3>() - F_S).norm(), 1e-12);
    EXPECT_LT((d.tail<3>() - c.cable.p_SA_S.cross(F_S)).norm(), 1e-12);
    EXPECT_GT(F_S.norm(), 1.0);
  }
}

TEST(CellSim, TemperatureDriftFollowsNonMonotonicTemperature) {
  CellSimConfig c = baseConfig();
  const CellSim off(c);
  c.temperature_drift.enabled = true;
  const CellSim on(c);
  const logio::LogData log = on.run();
  int rises = 0, falls = 0;
  for (std::size_t k = 1; k < log.samples.size(); ++k) {
    (log.samples[k].temp_degC > log.samples[k - 1].temp_degC ? rises : falls)++;
  }
  EXPECT_GT(rises, 100);  // default profile is not monotonic in time
  EXPECT_GT(falls, 100);
  for (double t : {0.0, 3.0, 9.0}) {
    const double T = c.temperature.at(t);
    const Wrench d = on.sampleAt(t).wrench_S - off.sampleAt(t).wrench_S;
    const double dT = T - c.temperature_drift.reference_degC;
    EXPECT_LT((d.head<3>() - c.temperature_drift.dF0_dT_N_per_degC * dT).norm(), 1e-12);
    EXPECT_LT((d.tail<3>() - c.temperature_drift.dT0_dT_Nm_per_degC * dT).norm(), 1e-12);
    EXPECT_DOUBLE_EQ(on.sampleAt(t).temp_degC, T);
  }
}

TEST(CellSim, TimeDriftIsLinearInTime) {
  CellSimConfig c = baseConfig();
  const CellSim off(c);
  c.time_drift.enabled = true;
  const CellSim on(c);
  for (double t : {0.0, 4.0, 10.0}) {
    const Wrench d = on.sampleAt(t).wrench_S - off.sampleAt(t).wrench_S;
    EXPECT_LT((d.head<3>() - c.time_drift.dF0_dt_N_per_s * t).norm(), 1e-12);
    EXPECT_LT((d.tail<3>() - c.time_drift.dT0_dt_Nm_per_s * t).norm(), 1e-12);
  }
}

TEST(CellSim, SensorDelayShiftsTheWrenchStreamExactly) {
  CellSimConfig c = baseConfig();
  c.temperature_drift.enabled = true;  // delayed offsets come along with the stream
  const CellSim off(c);
  c.sensor_delay.enabled = true;
  c.sensor_delay.tau_s = 3.0 / 125.0;  // three samples
  const CellSim on(c);
  const logio::LogData a = off.run(), b = on.run();
  ASSERT_EQ(a.samples.size(), b.samples.size());
  double max_change = 0.0;
  for (std::size_t k = 3; k < a.samples.size(); ++k) {
    EXPECT_LT((b.samples[k].wrench_S - a.samples[k - 3].wrench_S).norm(), 1e-9) << k;
    EXPECT_EQ(b.samples[k].q, a.samples[k].q);            // kinematics not delayed
    EXPECT_EQ(b.samples[k].acc_S, a.samples[k].acc_S);    // IMU not delayed
    max_change = std::max(max_change, (b.samples[k].wrench_S - a.samples[k].wrench_S).norm());
  }
  EXPECT_GT(max_change, 0.05);
  // A delay that is not a whole number of samples: exact re-evaluation at t - tau.
  c.sensor_delay.tau_s = 0.0137;
  const CellSim odd(c);
  for (double t : {1.0, 5.5}) {
    EXPECT_LT((odd.sampleAt(t).wrench_S - off.sampleAt(t - 0.0137).wrench_S).norm(), 1e-12);
  }
}

TEST(CellSim, CrosstalkMultipliesTheLoad) {
  CellSimConfig c = baseConfig();
  c.cable.enabled = true;
  const CellSim off(c);
  c.crosstalk.enabled = true;
  const CellSim on(c);
  for (double t : {0.5, 7.0}) {
    const Wrench o = off.offsetsAt(t, 0.0);
    const Wrench load = off.sampleAt(t).wrench_S - o;
    const Wrench expected = (Mat6::Identity() + c.crosstalk.E) * load + o;
    EXPECT_LT((on.sampleAt(t).wrench_S - expected).norm(), 1e-12);
    EXPECT_GT((on.sampleAt(t).wrench_S - off.sampleAt(t).wrench_S).norm(), 0.01);
  }
}

TEST(CellSim, ContactPushIsTheOnlyDifferenceAndIsLogged) {
  CellSimConfig c = baseConfig();
  const CellSim off(c);
  c.contact.enabled = true;
  const CellSim on(c);
  const logio::LogData a = off.run(), b = on.run();
  ASSERT_EQ(b.extra_names.size(), 6u);
  EXPECT_EQ(b.extra_names[0], "contact_fx");
  double peak = 0.0;
  for (std::size_t k = 0; k < a.samples.size(); ++k) {
    Wrench logged;
    for (int i = 0; i < 6; ++i) logged[i] = b.extra_columns[static_cast<std::size_t>(i)][k];
    EXPECT_LT((b.samples[k].wrench_S - a.samples[k].wrench_S - logged).norm(), 1e-12);
    const double t = b.samples[k].t;
    if (t <= c.contact.t_start_s || t >= c.contact.t_end_s) {
      EXPECT_EQ(logged.norm(), 0.0);
    }
    EXPECT_LT(std::abs(logged.tail<3>().dot(logged.head<3>())), 1e-12);  // pure force at a point
    peak = std::max(peak, logged.head<3>().norm());
  }
  EXPECT_NEAR(peak, c.contact.force_B.norm(), 1e-3);  // sin^2 window peaks at the middle sample
}

TEST(CellSim, SameSeedSameOutputAndNoiseHasConfiguredStd) {
  CellSimConfig c = baseConfig();
  c.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  c.noise.acc_std = 0.02;
  c.noise.gyro_std = 0.003;
  const logio::LogData a = CellSim(c).run();
  const logio::LogData b = CellSim(c).run();
  ASSERT_EQ(a.samples.size(), 1251u);
  for (std::size_t k = 0; k < a.samples.size(); ++k) {
    ASSERT_EQ(a.samples[k].wrench_S, b.samples[k].wrench_S);
    ASSERT_EQ(a.samples[k].acc_S, b.samples[k].acc_S);
  }
  c.seed = 43;
  const logio::LogData d = CellSim(c).run();
  EXPECT_NE(a.samples[10].wrench_S, d.samples[10].wrench_S);
  // Noise statistics against the noise-free stream.
  c.noise = NoiseConfig{};
  const logio::LogData clean = CellSim(c).run();
  Vec6 ss = Vec6::Zero();
  double acc_ss = 0.0;
  for (std::size_t k = 0; k < a.samples.size(); ++k) {
    ss += (a.samples[k].wrench_S - clean.samples[k].wrench_S).cwiseAbs2();
    acc_ss += (a.samples[k].acc_S - clean.samples[k].acc_S).squaredNorm();
  }
  const double n = static_cast<double>(a.samples.size());
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(std::sqrt(ss[i] / n), i < 3 ? 0.05 : 0.01, i < 3 ? 0.005 : 0.001);
  EXPECT_NEAR(std::sqrt(acc_ss / (3 * n)), 0.02, 0.002);
}

TEST(CellSim, RunRowsEqualPerInstantApi) {
  CellSimConfig c = baseConfig();
  c.cable.enabled = true;
  const CellSim sim(c);
  const logio::LogData log = sim.run();
  EXPECT_TRUE(log.has_imu);
  EXPECT_TRUE(log.has_temp);
  EXPECT_DOUBLE_EQ(log.samples.back().t, 10.0);
  for (std::size_t k : {std::size_t{0}, std::size_t{333}, std::size_t{1250}}) {
    const auto& s = log.samples[k];
    const SensorReading r = sim.readingAt(s.q, s.qd, s.qdd, s.t);
    EXPECT_EQ(r.wrench_S, s.wrench_S);
    EXPECT_EQ(r.acc_S, s.acc_S);
    EXPECT_EQ(r.temp_degC, s.temp_degC);
  }
}

TEST(CellSim, PaperTrajectoryIsRestToRestAndWithinLimits) {
  const trajectory::FourierTrajectory traj = paperExcitationTrajectory();
  EXPECT_EQ(traj.harmonics(), 5);
  EXPECT_DOUBLE_EQ(traj.baseFrequency(), 0.1);
  EXPECT_DOUBLE_EQ(traj.duration(), 10.0);
  for (double t : {0.0, 10.0}) {
    const auto p = traj.evaluate(t);
    EXPECT_LT(p.qd.norm() + p.qdd.norm(), 1e-12);
    EXPECT_LT((p.q - paperStartPose()).norm(), 1e-12);
  }
  const model::RobotKinematics kin = ur10();
  double vmax = 0.0;
  for (int k = 0; k <= 10000; ++k) {
    const auto p = traj.evaluate(k * 1e-3);
    for (int j = 0; j < 6; ++j) {
      ASSERT_LE(std::abs(p.qd[j]), kin.limits().velocity[j]);
      ASSERT_LE(std::abs(p.qdd[j]), kin.limits().acceleration[j]);
      ASSERT_GE(p.q[j], kin.limits().lower[j]);
      ASSERT_LE(p.q[j], kin.limits().upper[j]);
      if (j < 3) {
        ASSERT_EQ(p.q[j], paperStartPose()[j]);
      }
    }
    vmax = std::max(vmax, p.qd.cwiseAbs().maxCoeff());
  }
  EXPECT_GT(vmax, 0.5);
}

TEST(CellSim, InvalidConfigurationsThrowConfigError) {
  CellSimConfig c = baseConfig();
  c.robot.reset();
  EXPECT_THROW(CellSim{c}, ConfigError);
  c = baseConfig();
  c.payload.mass_kg = -1.0;
  EXPECT_THROW(CellSim{c}, ConfigError);
  c = baseConfig();
  c.payload.I_C_S = Vec3(0.001, 0.001, 0.01).asDiagonal();  // violates the triangle inequality
  try {
    CellSim s{c};
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("payload.I_C_S"), std::string::npos);
  }
  c = baseConfig();
  c.rate_hz = 0.0;
  EXPECT_THROW(CellSim{c}, ConfigError);
  c = baseConfig();
  c.contact.t_end_s = c.contact.t_start_s;
  EXPECT_THROW(CellSim{c}, ConfigError);
}

TEST(CellSim, TruthYamlCarriesTheParameters) {
  CellSimConfig c = paperCellConfig(ur10());
  c.sensor_delay.enabled = true;
  const YAML::Node y = YAML::Load(truthYaml(c));
  EXPECT_DOUBLE_EQ(y["parameters"]["weight"].as<double>(), 8.862);
  EXPECT_DOUBLE_EQ(y["parameters"]["com_z"].as<double>(), 0.051);
  EXPECT_DOUBLE_EQ(y["parameters"]["f0_x"].as<double>(), -0.6672);
  EXPECT_DOUBLE_EQ(y["parameters"]["tilt_u"].as<double>(), -9.8716 * kPi / 180.0);
  EXPECT_TRUE(y["effects"]["sensor_delay"]["enabled"].as<bool>());
  EXPECT_FALSE(y["effects"]["cable"]["enabled"].as<bool>());
  EXPECT_EQ(y["parameters"]["inertia"].size(), 6u);
  const std::string path = ftid::test::binaryPath("/sim_test_truth.yaml");
  writeTruthYaml(path, c);
  EXPECT_DOUBLE_EQ(YAML::LoadFile(path)["effects"]["sensor_delay"]["tau"].as<double>(), 0.012);
}

}  // namespace
}  // namespace ftid::sim
