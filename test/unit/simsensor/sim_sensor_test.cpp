// Sensor simulator: robot-state interpolation, configuration, frames vs. independent physics,
// fault injection, and the whole chain against the UR controller simulator over RTDE.
#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <thread>

#include "ftid/common/error.hpp"
#include "ftid/drivers/can/ft_imu_sensor.hpp"
#include "ftid/drivers/can/seqpacket.hpp"
#include "ftid/simrobot/sim_robot.hpp"
#include "ftid/simsensor/sim_sensor.hpp"
#include "test_paths.hpp"

namespace ftid::simsensor {
namespace {

const std::string kSrc = ftid::test::sourceDir();

JointVector homeQ() {
  return (JointVector() << 0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0).finished();
}

// ---- interpolation ------------------------------------------------------------------------

TEST(RobotHistory, HermiteIsExactForCubicMotion) {
  // q_j(t) = a + b t + c t^2 + d t^3 per joint, sampled every 8 ms.
  const auto q = [](double t, int j) { return 0.1 * j + 0.3 * t - 0.7 * t * t + 0.4 * (j + 1) * t * t * t; };
  const auto qd = [](double t, int j) { return 0.3 - 1.4 * t + 1.2 * (j + 1) * t * t; };
  const auto qdd = [](double t, int j) { return -1.4 + 2.4 * (j + 1) * t; };
  RobotHistory h;
  RobotHistory::Tick probe;
  EXPECT_FALSE(h.stateAt(0.0, probe));
  for (int k = 0; k < 100; ++k) {
    RobotHistory::Tick tk;
    tk.t = 50.0 + 0.008 * k;
    for (int j = 0; j < 6; ++j) {
      tk.q[j] = q(tk.t - 50.0, j);
      tk.qd[j] = qd(tk.t - 50.0, j);
      tk.qdd[j] = qdd(tk.t - 50.0, j);
    }
    h.add(tk);
  }
  EXPECT_NEAR(h.period(), 0.008, 1e-12);
  for (double t = 50.0011; t < 50.79; t += 0.00237) {
    RobotHistory::Tick x;
    ASSERT_TRUE(h.stateAt(t, x));
    for (int j = 0; j < 6; ++j) {
      EXPECT_NEAR(x.q[j], q(t - 50.0, j), 1e-12) << t;
      EXPECT_NEAR(x.qd[j], qd(t - 50.0, j), 1e-10) << t;
      EXPECT_NEAR(x.qdd[j], qdd(t - 50.0, j), 1e-10) << t;
    }
  }
}

TEST(RobotHistory, ExtrapolatesThenHoldsStill) {
  RobotHistory h;
  RobotHistory::Tick a;
  a.t = 10.0;
  a.q.setConstant(1.0);
  a.qd.setConstant(0.5);
  a.qdd.setConstant(-2.0);
  h.add(a);
  RobotHistory::Tick b = a;
  b.t = 10.008;
  b.q = a.q + a.qd * 0.008 + 0.5 * a.qdd * 0.008 * 0.008;
  b.qd = a.qd + a.qdd * 0.008;
  h.add(b);
  h.add(a);  // older than the newest: ignored
  EXPECT_EQ(h.size(), 2u);
  RobotHistory::Tick x;
  const double dt = 0.005;  // within three periods: constant acceleration
  h.stateAt(b.t + dt, x);
  EXPECT_NEAR(x.q[0], b.q[0] + b.qd[0] * dt + 0.5 * b.qdd[0] * dt * dt, 1e-13);
  EXPECT_NEAR(x.qd[0], b.qd[0] + b.qdd[0] * dt, 1e-13);
  h.stateAt(b.t + 1.0, x);  // stream stopped: held still
  EXPECT_DOUBLE_EQ(x.q[0], b.q[0]);
  EXPECT_EQ(x.qd.norm(), 0.0);
  EXPECT_EQ(x.qdd.norm(), 0.0);
  h.stateAt(0.0, x);  // before the oldest: the oldest
  EXPECT_DOUBLE_EQ(x.q[0], a.q[0]);
  // A controller restart (clock back to its start value) restarts the history.
  EXPECT_EQ(h.generation(), 0u);
  RobotHistory::Tick restarted;
  restarted.t = 5.0;
  restarted.q.setConstant(-1.0);
  h.add(restarted);
  EXPECT_EQ(h.generation(), 1u);
  EXPECT_EQ(h.size(), 1u);
  h.stateAt(5.001, x);
  EXPECT_DOUBLE_EQ(x.q[0], -1.0);
}

// ---- configuration ------------------------------------------------------------------------

TEST(SimSensorConfig, ShippedYamlIsThePaperCell) {
  SimSensorConfig c = defaultSimSensorConfig();
  loadSimSensorYaml(kSrc + "/config/sim_sensor.yaml", c);
  EXPECT_NEAR(c.cell.payload.mass_kg * kStandardGravity, 8.862, 1e-12);
  EXPECT_NEAR(c.cell.payload.p_SC_S.z(), 0.051, 1e-15);
  EXPECT_NEAR(c.cell.tilt_u_rad, -9.8716 * M_PI / 180.0, 1e-12);
  EXPECT_NEAR(c.cell.F0_N.x(), -0.6672, 1e-15);
  EXPECT_EQ(c.rate_hz, 1000.0);
  EXPECT_EQ(c.socket_path, "/run/ftid/ftsensor.sock");
  EXPECT_FALSE(c.cell.cable.enabled);
  EXPECT_FALSE(c.cell.sensor_delay.enabled);
  EXPECT_TRUE(c.faults.empty());
  EXPECT_EQ(c.cell.noise.wrench_std.norm(), 0.0);
}

TEST(SimSensorConfig, ErrorsNameFileLineAndKey) {
  const std::string path = "/tmp/ftid-simsensor-cfg-" + std::to_string(getpid()) + ".yaml";
  const auto expectError = [&](const std::string& text, const std::string& fragment) {
    {
      std::ofstream(path) << text;
    }
    SimSensorConfig c = defaultSimSensorConfig();
    try {
      loadSimSensorYaml(path, c);
      FAIL() << text;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  };
  expectError("output:\n  rate_hz: fast\n", ":2:12: key 'output.rate_hz': expected a number");
  expectError("output:\n  rate_hz: 20000\n", ":2:12: key 'output.rate_hz': must be in (0, 10000], got 20000");
  expectError("effects:\n  cabel: {enabled: true}\n", ":2:3: key 'effects.cabel': unknown key");
  expectError("tilt_deg: [1, 2, 3]\n", ":1:11: key 'tilt_deg': expected a list of 2 numbers");
  expectError("faults:\n  - {at_s: 1, kind: explode}\n", ":2:21: key 'faults[0].kind'");
  expectError("faults:\n  - {kind: drop}\n", ":2:5: key 'faults[0].at_s': missing");
  expectError("seed: -3\n", ":1:7: key 'seed': must be a non-negative integer");
  expectError("output: [\n", "YAML syntax error");
  SimSensorConfig c = defaultSimSensorConfig();
  {
    std::ofstream(path) << "effects:\n  sensor_delay: {enabled: true, tau_s: 0.02}\n"
                           "faults:\n  - {at_s: 2.5, kind: silent, count: 40}\n"
                           "payload: {mass_kg: 2.0, com_m: [0, 0, 0.1]}\n";
  }
  loadSimSensorYaml(path, c);
  EXPECT_TRUE(c.cell.sensor_delay.enabled);
  EXPECT_DOUBLE_EQ(c.cell.sensor_delay.tau_s, 0.02);
  ASSERT_EQ(c.faults.size(), 1u);
  EXPECT_EQ(c.faults[0].kind, SensorFault::kSilent);
  EXPECT_EQ(c.faults[0].count, 40);
  EXPECT_DOUBLE_EQ(c.cell.payload.mass_kg, 2.0);
  std::remove(path.c_str());
  EXPECT_THROW(enableEffect("gravity_off", c), ConfigError);
  enableEffect("cable", c);
  EXPECT_TRUE(c.cell.cable.enabled);
  EXPECT_THROW(parseSensorFault("boom"), ConfigError);
  EXPECT_EQ(parseSensorFault("bus_off"), SensorFault::kBusOff);
}

// ---- frames vs. independent physics -------------------------------------------------------

// Gravity in S for a robot at rest, from the simulator's own UR DH forward kinematics (not KDL) and
// the tilt formula of docs/conventions.md (paper Eq. 13). S = F (identity mount).
Vec3 gravityInSensor(const JointVector& q, double U, double V) {
  const Vec6 pose = simrobot::forwardKinematicsTcpPose(simrobot::RobotModel::kUR10, q);
  const Vec3 rv = pose.tail<3>();
  const Mat3 R_BF = rv.norm() > 0 ? Eigen::AngleAxisd(rv.norm(), rv.normalized()).toRotationMatrix()
                                  : Mat3::Identity();
  const Vec3 g_B = kStandardGravity *
                   Vec3(std::cos(U) * std::sin(V), -std::sin(U), -std::cos(U) * std::cos(V));
  return R_BF.transpose() * g_B;
}

class FrameSourceTest : public ::testing::Test {
 protected:
  FrameSourceTest()
      : layout_(drivers::can::SensorLayout::fromDbc(drivers::can::loadDbc(kSrc + "/config/ftsensor.dbc"))),
        config_(defaultSimSensorConfig()) {
    config_.cell.temperature_drift.enabled = false;
  }
  void holdAt(const JointVector& q) {
    for (int k = 0; k < 4; ++k) {
      RobotHistory::Tick t;
      t.t = 50.0 + 0.008 * k;
      t.q = q;
      history_.add(t);
    }
  }
  drivers::can::SensorLayout layout_;
  SimSensorConfig config_;
  RobotHistory history_;
};

TEST_F(FrameSourceTest, FramesAtRestMatchIndependentStatics) {
  SensorFrameSource src(config_, layout_, model::RobotKinematics::fromUrdfFile(kSrc + "/config/ur10.urdf"));
  drivers::can::SampleAssembler asm_(layout_);
  std::array<can_frame, SensorFrameSource::kMaxFrames> frames{};
  const JointVector poses[] = {homeQ(),
                               (JointVector() << 0.3, -1.2, 1.9, -0.4, 1.1, 2.0).finished(),
                               (JointVector() << -1.0, -2.0, 0.5, 1.5, -0.7, -2.5).finished()};
  int k = 0;
  for (const JointVector& q : poses) {
    RobotHistory h;
    RobotHistory::Tick t;
    t.t = 50.0 + k;
    t.q = q;
    h.add(t);
    const int n = src.nextSample(h, t.t, 0.5, frames);
    ASSERT_EQ(n, 6);
    drivers::can::ReceivedFrame rf;
    for (int i = 0; i < n; ++i) {
      rf.frame = frames[static_cast<std::size_t>(i)];
      rf.rx_time_ns = 1000 + k;
      asm_.feed(rf);
    }
    drivers::can::SensorSample s;
    asm_.readLatest(s, 1000 + k);
    ASSERT_TRUE(s.valid) << s.health_flags;
    EXPECT_EQ(s.counter, static_cast<std::uint32_t>(k));
    const auto& c = config_.cell;
    const Vec3 g_S = gravityInSensor(q, c.tilt_u_rad, c.tilt_v_rad);
    const Vec3 f = c.payload.mass_kg * g_S + c.F0_N;
    const Vec3 tq = c.payload.p_SC_S.cross(c.payload.mass_kg * g_S) + c.T0_Nm;
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(s.wrench_S[i], f[i], 0.025 + 1e-6) << "pose " << k << " axis " << i;
      EXPECT_NEAR(s.wrench_S[3 + i], tq[i], 0.0005 + 1e-6) << "pose " << k << " axis " << i;
      EXPECT_NEAR(s.acc_S[i], -g_S[i], 0.001 + 1e-6);  // specific force at rest = -g
      EXPECT_NEAR(s.w_S[i], 0.0, 1e-12);
    }
    EXPECT_NEAR(s.temp_degC, c.temperature.at(0.5), 0.005 + 1e-9);
    ++k;
  }
}

TEST_F(FrameSourceTest, InjectedFaultsShowUpInTheFrames) {
  holdAt(homeQ());
  SensorFrameSource src(config_, layout_, model::RobotKinematics::fromUrdfFile(kSrc + "/config/ur10.urdf"));
  drivers::can::SensorHealthOptions ho;
  ho.stale_timeout_ns = 3'500'000;  // 3.5 samples at 1 kHz
  drivers::can::SampleAssembler a(layout_, ho);
  std::array<can_frame, SensorFrameSource::kMaxFrames> frames{};
  std::int64_t t_ns = 0;
  drivers::can::SensorSample s;
  const auto step = [&]() {
    t_ns += 1'000'000;
    const int n = src.nextSample(history_, 50.03, 1.0, frames);
    for (int i = 0; i < n; ++i) {
      drivers::can::ReceivedFrame rf;
      rf.frame = frames[static_cast<std::size_t>(i)];
      rf.rx_time_ns = t_ns;
      a.feed(rf);
    }
    a.readLatest(s, t_ns);
    return n;
  };
  for (int i = 0; i < 5; ++i) step();
  EXPECT_TRUE(s.valid);
  src.inject(SensorFault::kSilent, 5);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(step(), 0);
  EXPECT_FALSE(s.valid);  // stale after 3.5 ms of silence
  EXPECT_TRUE(s.health_flags & kHealthStale);
  step();
  EXPECT_TRUE(s.valid);
  EXPECT_TRUE(s.health_flags & kHealthCounterGap);
  EXPECT_EQ(a.health().samples_lost, 5u);

  src.inject(SensorFault::kCounterGap, 7);
  step();
  EXPECT_EQ(a.health().samples_lost, 12u);

  src.inject(SensorFault::kOutOfRange, 2);
  step();
  EXPECT_FALSE(s.valid);
  EXPECT_TRUE(s.health_flags & kHealthOutOfRange);
  EXPECT_NEAR(s.wrench_S[0], 360.0, 0.03);
  step();
  step();
  EXPECT_TRUE(s.valid);

  src.inject(SensorFault::kStuckCounter, 1);
  step();
  step();
  EXPECT_TRUE(s.health_flags & kHealthCounterRepeat);
  EXPECT_FALSE(s.valid);
  step();
  EXPECT_TRUE(s.valid);

  src.inject(SensorFault::kStatusFault, 1);
  step();
  EXPECT_FALSE(s.valid);
  EXPECT_EQ(s.status_word, 0x2u);

  src.inject(SensorFault::kErrorFrame, 2);
  EXPECT_EQ(step(), 8);
  EXPECT_EQ(a.health().error_frames, 2u);
  src.inject(SensorFault::kBusOff, 1);
  step();
  EXPECT_EQ(a.health().bus_off_events, 1u);
}

TEST_F(FrameSourceTest, SensorDelayShiftsOnlyTheWrench) {
  // A moving robot (joint 4-6 sinusoids) sampled at 125 Hz.
  RobotHistory h;
  for (int k = 0; k < 200; ++k) {
    RobotHistory::Tick t;
    t.t = 50.0 + 0.008 * k;
    const double s = t.t - 50.0;
    t.q = homeQ();
    for (int j = 3; j < 6; ++j) {
      t.q[j] += 0.5 * std::sin(2.0 * s + j);
      t.qd[j] = 1.0 * std::cos(2.0 * s + j);
      t.qdd[j] = -2.0 * std::sin(2.0 * s + j);
    }
    h.add(t);
  }
  const auto kin = model::RobotKinematics::fromUrdfFile(kSrc + "/config/ur10.urdf");
  SensorFrameSource plain(config_, layout_, kin);
  SimSensorConfig delayed_cfg = config_;
  delayed_cfg.cell.sensor_delay.enabled = true;
  delayed_cfg.cell.sensor_delay.tau_s = 0.012;
  SensorFrameSource delayed(delayed_cfg, layout_, kin);
  const double t_robot = 50.8;
  const sim::SensorReading now = plain.readingAt(h, t_robot, 0.8);
  const sim::SensorReading before = plain.readingAt(h, t_robot - 0.012, 0.8 - 0.012);
  const sim::SensorReading d = delayed.readingAt(h, t_robot, 0.8);
  EXPECT_LT((d.wrench_S - before.wrench_S).norm(), 1e-12);
  EXPECT_GT((now.wrench_S - before.wrench_S).norm(), 1e-3);  // the motion is fast enough to see
  EXPECT_LT((d.acc_S - now.acc_S).norm(), 1e-12);             // the IMU is not delayed
  EXPECT_LT((d.w_S - now.w_S).norm(), 1e-12);
}

TEST_F(FrameSourceTest, GraspOnRequestAddsTheObjectsWeightFromTheNextSampleOn) {
  // `--effect grasp:mass=0.6,com=0/0/0.12` without t: nothing until requestGrasp() (SIGRTMIN+2),
  // then the object's static wrench m g_S and p x m g_S (independent statics, gravityInSensor).
  enableEffect("grasp:mass=0.6,com=0/0/0.12,side=0.06", config_);
  EXPECT_FALSE(config_.cell.payload_change.enabled);
  const auto kin = model::RobotKinematics::fromUrdfFile(kSrc + "/config/ur10.urdf");
  SensorFrameSource src(config_, layout_, kin);
  const JointVector q = (JointVector() << 0.3, -1.2, 1.9, -0.4, 1.1, 2.0).finished();
  holdAt(q);
  std::array<can_frame, SensorFrameSource::kMaxFrames> frames{};
  const sim::SensorReading before = src.readingAt(history_, 50.02, 3.0);
  ASSERT_EQ(src.nextSample(history_, 50.02, 3.0, frames), 6);
  EXPECT_LT((src.readingAt(history_, 50.02, 100.0).wrench_S - before.wrench_S).norm(), 1e-9);  // never by itself
  src.requestGrasp();
  ASSERT_EQ(src.nextSample(history_, 50.02, 3.0, frames), 6);
  const sim::SensorReading after = src.readingAt(history_, 50.02, 3.001);
  const Vec3 g_S = gravityInSensor(q, config_.cell.tilt_u_rad, config_.cell.tilt_v_rad);
  const Vec3 df = 0.6 * g_S;
  const Vec3 dt = Vec3(0.0, 0.0, 0.12).cross(df);
  EXPECT_LT((after.wrench_S.head<3>() - before.wrench_S.head<3>() - df).norm(), 1e-6);
  EXPECT_LT((after.wrench_S.tail<3>() - before.wrench_S.tail<3>() - dt).norm(), 1e-6);
  // Before the grasp's time (the source's t_phys 3.0) the object is not there.
  EXPECT_LT((src.readingAt(history_, 50.02, 2.9).wrench_S - before.wrench_S).norm(), 1e-9);
  SimSensorConfig bad = defaultSimSensorConfig();
  EXPECT_THROW(enableEffect("grasp:mass=-1", bad), ConfigError);
  EXPECT_THROW(enableEffect("grasp:weight=1", bad), ConfigError);
}

// ---- the whole chain: sim-robot --RTDE--> sim-sensor --seqpacket--> CanFtImuSensor ----------

TEST(SimSensorEndToEnd, ServesValidSamplesFromTheRobotSimulator) {
  simrobot::SimRobotConfig rc;
  rc.rtde_port = 0;
  rc.dashboard_port = 0;
  rc.script_port = 0;
  simrobot::SimRobot robot(rc);
  robot.start();

  SimSensorConfig cfg = defaultSimSensorConfig();
  cfg.rtde_port = robot.rtdePort();
  cfg.urdf_path = kSrc + "/config/ur10.urdf";
  cfg.dbc_path = kSrc + "/config/ftsensor.dbc";
  cfg.socket_path = "/tmp/ftid-simsensor-e2e-" + std::to_string(getpid()) + ".sock";
  cfg.rate_hz = 1000.0;
  SimSensor sensor(cfg);
  std::atomic<bool> stop{false};
  std::thread runner([&] { sensor.run(stop); });

  drivers::can::CanSensorConfig sc;
  sc.endpoint = "seqpacket:" + cfg.socket_path;
  sc.dbc_path = cfg.dbc_path;
  auto client = drivers::can::openCanSensor(sc);
  drivers::can::SensorSample s;
  std::uint64_t first_seq = 0;
  int valid_reads = 0;
  // 60 reads take ~0.5 s; the deadline only bounds a broken chain, with room for the start-up
  // (RTDE connect, first robot state) on a loaded machine.
  const auto t_start = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - t_start < std::chrono::seconds(20)) {
    std::this_thread::sleep_for(std::chrono::milliseconds(8));  // a 125 Hz consumer
    if (client->tryReadLatest(s) != Status::kOk) continue;
    if (first_seq == 0) first_seq = s.sequence;
    if (++valid_reads == 60) break;
  }
  const auto elapsed = std::chrono::steady_clock::now() - t_start;
  stop = true;
  runner.join();
  ASSERT_EQ(valid_reads, 60) << "no valid samples from sim-sensor";
  // About 8 samples per 8 ms read: 1 kHz, drained to latest, none lost.
  const double samples = static_cast<double>(s.sequence - first_seq);
  EXPECT_GT(samples, 59 * 5.0);
  // Nothing is lost on the way: samples missing at the client are exactly those the simulator
  // skipped after a scheduling stall (none on an idle machine), and no group is incomplete unless
  // the server had to drop frames for a full client queue.
  const SimSensorStats st = sensor.stats();
  EXPECT_EQ(client->health().samples_lost, st.skipped_samples);
  if (st.frames_dropped == 0) {
    EXPECT_EQ(client->health().samples_incomplete, 0u);
  }
  EXPECT_EQ(client->health().out_of_range, 0u);
  EXPECT_EQ(client->health().error_frames, 0u);
  EXPECT_GE(st.robot_ticks, 10u);
  EXPECT_GT(st.frames_sent, 6 * static_cast<std::uint64_t>(samples));
  (void)elapsed;
  // The robot sits at its home pose: the reading is the payload's static load (independent
  // kinematics and tilt formula, as above).
  const auto& c = cfg.cell;
  const Vec3 g_S = gravityInSensor(homeQ(), c.tilt_u_rad, c.tilt_v_rad);
  const Vec3 f = c.payload.mass_kg * g_S + c.F0_N;
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(s.wrench_S[i], f[i], 0.03);
    EXPECT_NEAR(s.acc_S[i], -g_S[i], 0.002);
  }
  robot.stop();
}

}  // namespace
}  // namespace ftid::simsensor
