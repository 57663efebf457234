// The production chain (parameter file -> ParameterFileCompensation, URDF -> KinematicsMotionModel)
// inside DaemonCycle, checked against an INDEPENDENT formulation: UR10 forward kinematics from the
// standard DH table (docs/conventions.md), gravity from the paper's Eq. 13, and the static
// wrench f = m g_S + F0 + F_ext, t = c x (m g_S) + T0 + p x F_ext. The published contact wrench
// must be the applied contact [F_ext; p x F_ext].
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <random>

#include "fakes.hpp"
#include "ftid/common/error.hpp"
#include "ftid/daemon/adapters.hpp"
#include "ftid/daemon/daemon_cycle.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/params/parameter_set.hpp"
#include "ftid/sim/cell_sim.hpp"
#include "test_paths.hpp"

namespace ftid::daemon {
namespace {

// R_BF of the UR10 from standard DH: T_i = Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i).
Mat3 ur10FlangeRotation(const JointVector& q) {
  const double alpha[6] = {M_PI / 2, 0, 0, M_PI / 2, -M_PI / 2, 0};
  Mat3 R = Mat3::Identity();
  for (int i = 0; i < 6; ++i) {
    const Mat3 rz = Eigen::AngleAxisd(q(i), Vec3::UnitZ()).toRotationMatrix();
    const Mat3 rx = Eigen::AngleAxisd(alpha[i], Vec3::UnitX()).toRotationMatrix();
    R = R * rz * rx;
  }
  return R;
}

struct Payload {
  double m = 2.5;
  Vec3 c{0.01, -0.02, 0.08};
  Vec3 F0{1.5, -0.7, 3.2};
  Vec3 T0{0.05, -0.03, 0.01};
  double tilt_u = 0.012;
  double tilt_v = -0.021;
};

std::string writeParams(const Payload& p, const std::string& path) {
  const effects::Model model = effects::Model::fromName("paper");
  std::map<std::string, double> v = {
      {"mass", p.m},          {"mass_com_x", p.m * p.c.x()}, {"mass_com_y", p.m * p.c.y()},
      {"mass_com_z", p.m * p.c.z()}, {"f0_x", p.F0.x()},     {"f0_y", p.F0.y()},
      {"f0_z", p.F0.z()},     {"t0_x", p.T0.x()},            {"t0_y", p.T0.y()},
      {"t0_z", p.T0.z()}};
  params::ParameterSet set;
  set.model = model.name();
  for (const auto& name : model.paramIndex().names()) {
    const auto it = v.find(name);
    if (it == v.end()) throw Error("test does not know parameter " + name);
    set.params.push_back({name, it->second, 0.0, ""});
  }
  set.tilt_estimated = true;
  set.tilt_u_rad = p.tilt_u;
  set.tilt_v_rad = p.tilt_v;
  params::writeParameterFile(path, set);
  return path;
}

TEST(DaemonCompensation, ContactWrenchMatchesAnIndependentStaticModel) {
  const std::string path =
      ::testing::TempDir() + "ftid_daemon_params_" + std::to_string(::getpid()) + ".yaml";
  const Payload p;
  writeParams(p, path);

  model::RobotKinematics kin = model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/ur10.urdf"));
  KinematicsMotionModel motion(kin);
  rt::OwnedSwapSlot<Compensation> slot(std::make_unique<ParameterFileCompensation>(path));
  test::FakeArm arm;
  test::FakeSensor sensor;
  test::RecordingSink sink;
  CycleOptions opt;
  opt.now_us = &test::fakeNowUs;
  DaemonCycle cycle(&arm, &sensor, &motion, &slot, &sink, opt);

  const double g = kStandardGravity;
  const Vec3 g_B(g * std::cos(p.tilt_u) * std::sin(p.tilt_v), -g * std::sin(p.tilt_u),
                 -g * std::cos(p.tilt_u) * std::cos(p.tilt_v));
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> ang(-2.5, 2.5);
  std::uniform_real_distribution<double> force(-20.0, 20.0);
  for (int k = 0; k < 20; ++k) {
    JointVector q;
    for (int j = 0; j < 6; ++j) q(j) = ang(rng);
    const Mat3 R_BS = ur10FlangeRotation(q);  // S = F (identity mount)
    const Vec3 g_S = R_BS.transpose() * g_B;
    const Vec3 F_ext(force(rng), force(rng), force(rng));
    const Vec3 p_contact(0.02, 0.01, 0.15);
    Wrench reading;
    reading.head<3>() = p.m * g_S + p.F0 + F_ext;
    reading.tail<3>() = p.c.cross(p.m * g_S) + p.T0 + p_contact.cross(F_ext);
    sensor.sample.wrench_S = reading;
    arm.state.q = q;
    arm.state.qd.setZero();
    arm.state.qdd.setZero();
    test::g_fake_now_us += 8000;
    ASSERT_EQ(cycle.waitForTick(std::chrono::milliseconds(12)), Status::kOk);
    cycle.onTick();
    const auto& r = sink.records[static_cast<std::size_t>(sink.count - 1)];
    ASSERT_TRUE(r.wrench_valid);
    Wrench expected;
    expected.head<3>() = F_ext;
    expected.tail<3>() = p_contact.cross(F_ext);
    EXPECT_LT((r.contact_S - expected).norm(), 1e-6) << "pose " << k << "\n"
                                                     << r.contact_S.transpose() << "\n"
                                                     << expected.transpose();
    EXPECT_LT((r.modelled_S + expected - reading).norm(), 1e-6);
  }
  std::remove(path.c_str());
}

// The robot MOVES (qd, qdd != 0): the arm reports the excitation's joint state, the sensor reads
// the cell simulator's own Newton-Euler physics (src/sim: never the regressor) with a contact push,
// and the parameter file holds the simulator's truth (inertia about S by the parallel-axis theorem,
// written out here). A wrong sign or a lost term anywhere in the daemon's motion path (qd, qdd, the
// kinematics, the inertial effects, the delay line) shows as contact where there is none.
struct MovingCase {
  const char* name;
  const char* model;
  double delay_s;
};

void PrintTo(const MovingCase& c, std::ostream* os) { *os << c.name; }

class DaemonMovingCompensation : public ::testing::TestWithParam<MovingCase> {};

TEST_P(DaemonMovingCompensation, ContactIsTheSimulatorsPushWhileTheArmMoves) {
  const MovingCase mc = GetParam();
  model::RobotKinematics kin = model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/ur10.urdf"));
  sim::CellSimConfig cfg = sim::paperCellConfig(kin);
  cfg.full_rigid_body = true;
  cfg.contact.enabled = true;
  cfg.contact.t_start_s = 3.0;
  cfg.contact.t_end_s = 4.0;
  if (mc.delay_s != 0.0) {
    cfg.sensor_delay.enabled = true;
    cfg.sensor_delay.tau_s = mc.delay_s;
  }
  const sim::CellSim cell(cfg);

  // The truth as a parameter file of the model.
  const sim::PayloadTruth& pl = cfg.payload;
  const Vec3 c = pl.p_SC_S;
  const Mat3 I_S = pl.I_C_S + pl.mass_kg * (c.squaredNorm() * Mat3::Identity() - c * c.transpose());
  std::map<std::string, double> v = {
      {"mass", pl.mass_kg},      {"mass_com_x", pl.mass_kg * c.x()}, {"mass_com_y", pl.mass_kg * c.y()},
      {"mass_com_z", pl.mass_kg * c.z()}, {"f0_x", cfg.F0_N.x()},   {"f0_y", cfg.F0_N.y()},
      {"f0_z", cfg.F0_N.z()},    {"t0_x", cfg.T0_Nm.x()},           {"t0_y", cfg.T0_Nm.y()},
      {"t0_z", cfg.T0_Nm.z()},   {"i_s_xx", I_S(0, 0)},             {"i_s_yy", I_S(1, 1)},
      {"i_s_zz", I_S(2, 2)},     {"i_s_xy", I_S(0, 1)},             {"i_s_xz", I_S(0, 2)},
      {"i_s_yz", I_S(1, 2)},     {"delay", mc.delay_s}};
  const effects::Model model = effects::Model::fromName(mc.model);
  params::ParameterSet set;
  set.model = model.name();
  for (const auto& name : model.paramIndex().names()) set.params.push_back({name, v.at(name), 0.0, ""});
  if (model.estimatesDelay()) set.params.push_back({"delay", mc.delay_s, 0.0, "s"});
  set.tilt_u_rad = cfg.tilt_u_rad;
  set.tilt_v_rad = cfg.tilt_v_rad;
  const std::string path = ::testing::TempDir() + "ftid_daemon_moving_" + mc.name + "_" +
                           std::to_string(::getpid()) + ".yaml";
  params::writeParameterFile(path, set);

  KinematicsMotionModel motion(kin);
  rt::OwnedSwapSlot<Compensation> slot(std::make_unique<ParameterFileCompensation>(path));
  std::remove(path.c_str());
  test::FakeArm arm;
  test::FakeSensor sensor;
  test::RecordingSink sink;
  CycleOptions opt;
  opt.now_us = &test::fakeNowUs;
  DaemonCycle cycle(&arm, &sensor, &motion, &slot, &sink, opt);

  const double t_robot0 = arm.state.robot_time + 0.008;  // first tick's robot time
  double worst = 0.0, peak = 0.0, raw_dynamic = 0.0, max_qdd = 0.0;
  int valid = 0;
  const int n = 7 * 125;
  for (int k = 0; k < n; ++k) {
    const double t = k * 0.008;
    const trajectory::TrajectoryPoint x = cell.stateAt(t);
    const sim::SensorReading r = cell.sampleAt(t);
    arm.state.q = x.q;
    arm.state.qd = x.qd;
    arm.state.qdd = x.qdd;
    sensor.sample.wrench_S = r.wrench_S;
    test::g_fake_now_us += 8000;
    ASSERT_EQ(cycle.waitForTick(std::chrono::milliseconds(12)), Status::kOk);
    cycle.onTick();
    const auto& rec = sink.records[static_cast<std::size_t>((sink.count - 1) % test::RecordingSink::kCapacity)];
    EXPECT_NEAR(rec.robot.robot_time - t_robot0, t, 1e-9);
    max_qdd = std::max(max_qdd, x.qdd.cwiseAbs().maxCoeff());
    if (!rec.wrench_valid) {
      EXPECT_LT(t, std::abs(mc.delay_s) + 0.02) << "only the delay line's filling may be invalid";
      continue;
    }
    ++valid;
    const Wrench truth = r.contact_S;
    worst = std::max(worst, (rec.contact_S - truth).cwiseAbs().maxCoeff());
    peak = std::max(peak, truth.head<3>().norm());
    // The dynamic part the daemon must remove: the reading minus its static (gravity) part.
    const Wrench statics = cell.readingAt(x.q, JointVector::Zero(), JointVector::Zero(), t).wrench_S;
    raw_dynamic = std::max(raw_dynamic, (cell.readingAt(x.q, x.qd, x.qdd, t).wrench_S - statics).cwiseAbs().maxCoeff());
    if (sink.count >= test::RecordingSink::kCapacity) sink.count = 0;
  }
  EXPECT_GT(max_qdd, 0.5);        // the arm really accelerates
  EXPECT_GT(raw_dynamic, 0.2);    // and the inertial wrench is far above the tolerance
  EXPECT_NEAR(peak, 8.0, 0.05);   // the push happened (sampled near its peak)
  EXPECT_GT(valid, n - 10);
  EXPECT_LT(worst, 2e-3) << "largest |contact - truth| while moving";
}

INSTANTIATE_TEST_SUITE_P(Models, DaemonMovingCompensation,
                         ::testing::Values(MovingCase{"rigid_body", "paper+rigid_body", 0.0},
                                           MovingCase{"delay_24ms", "paper+rigid_body+sensor_delay", 0.024}),
                         [](const ::testing::TestParamInfo<MovingCase>& p) { return std::string(p.param.name); });

TEST(DaemonCompensation, BadParameterFileIsAConfigErrorNamingTheFile) {
  const std::string path =
      ::testing::TempDir() + "ftid_daemon_bad_" + std::to_string(::getpid()) + ".yaml";
  {
    std::FILE* f = std::fopen(path.c_str(), "w");
    std::fputs("model: paper\nparams: 3\n", f);
    std::fclose(f);
  }
  try {
    ParameterFileCompensation c(path);
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  EXPECT_THROW(ParameterFileCompensation(path + ".missing"), ConfigError);
  std::remove(path.c_str());
}

}  // namespace
}  // namespace ftid::daemon
