// The simulator's kinematics (against a hand-computed DH table),
// its register-protocol emulation for ur_rtde's program header, and its servo/safety model.
#include <gtest/gtest.h>

#include <cmath>
#include <thread>

#include "ftid/common/error.hpp"
#include "ftid/drivers/ur/rtde_client.hpp"
#include "ftid/simrobot/sim_robot.hpp"

using namespace std::chrono_literals;
using ftid::JointVector;
using ftid::Vec6;
namespace sim = ftid::simrobot;
namespace ur = ftid::drivers::ur;

TEST(SimKinematics, MatchesNotesTable) {
  struct Row {
    sim::RobotModel m;
    JointVector q;
    Vec6 pose;
  };
  const double h = 1.5707963267948966;
  std::vector<Row> rows;
  Row r;
  r = {sim::RobotModel::kUR10, JointVector::Zero(), Vec6()};
  r.pose << -1.1843, -0.256141, 0.0116, 1.570796, 0, 0;
  rows.push_back(r);
  r.q << 0, -h, 0, -h, 0, 0;
  r.pose << 0, -0.256141, 1.4273, 0, -2.221441, 2.221441;
  rows.push_back(r);
  r.q << 0.1, -1.2, 1.3, -1.7, -1.57, 0.4;
  r.pose << -0.888629, -0.253998, 0.551791, -2.516809, -1.855957, 0.03991;
  rows.push_back(r);
  r = {sim::RobotModel::kUR10e, JointVector::Zero(), Vec6()};
  r.pose << -1.18425, -0.2907, 0.06085, 1.570796, 0, 0;
  rows.push_back(r);
  r.q << 0, -h, 0, -h, 0, 0;
  r.pose << 0, -0.2907, 1.4848, 0, -2.221441, 2.221441;
  rows.push_back(r);
  for (const auto& row : rows) {
    const Vec6 p = sim::forwardKinematicsTcpPose(row.m, row.q);
    EXPECT_LT((p.head<3>() - row.pose.head<3>()).cwiseAbs().maxCoeff(), 2e-6) << p.transpose();
    // Compare orientations as matrices: at an angle of pi, v and -v are the same rotation.
    auto R = [](const Vec6& v) {
      const Eigen::Vector3d rv = v.tail<3>();
      return Eigen::AngleAxisd(rv.norm(), rv.norm() > 0 ? Eigen::Vector3d(rv.normalized()) : Eigen::Vector3d::UnitX())
          .toRotationMatrix();
    };
    EXPECT_LT((R(p) - R(row.pose)).cwiseAbs().maxCoeff(), 5e-6) << p.transpose() << "\nvs " << row.pose.transpose();
    EXPECT_NEAR(p.tail<3>().norm(), row.pose.tail<3>().norm(), 5e-6);
  }
}

namespace {

struct Client {
  ur::RtdeClient c;
  ur::InputPackage servo, cmd;
  ur::RtdeStatePackage s;
  explicit Client(std::uint16_t port) {
    c.connect("127.0.0.1", port);
    c.negotiateProtocolVersion();
    c.setupOutputs(125, {"timestamp", "actual_q", "target_q", "target_qd", "runtime_state", "safety_mode",
                         "safety_status_bits", "output_int_register_0", "output_double_register_0"});
    std::vector<std::string> names = {"input_int_register_0"};
    for (int k = 0; k <= 10; ++k) names.push_back("input_double_register_" + std::to_string(k));
    servo = ur::InputPackage(c.setupInputs(names));
    cmd = ur::InputPackage(c.setupInputs({"input_int_register_0", "input_double_register_0"}));
    c.start();
  }
  // The bound only has to outlast a scheduling hiccup of a loaded machine: the tests count
  // packages (each call consumes at least one controller tick), they do not time them.
  void next() { ASSERT_EQ(c.tryReceiveState(1000ms, &s), ftid::Status::kOk); }
  template <class P>
  bool waitFor(P pred, int ticks = 200) {
    for (int i = 0; i < ticks; ++i) {
      next();
      if (pred(s)) return true;
    }
    return false;
  }
  void command(int code, double arg = 0) {
    cmd.setInt32(0, code);
    cmd.setDouble(1, arg);
    c.trySendInputs(cmd);
  }
  void servoTo(const JointVector& q) {
    servo.setInt32(0, 11);
    for (int i = 0; i < 6; ++i) servo.setDouble(static_cast<std::size_t>(1 + i), q[i]);
    servo.setDouble(9, 0.008);
    servo.setDouble(10, 0.1);
    servo.setDouble(11, 300);
    c.trySendInputs(servo);
  }
};

sim::SimRobotConfig config() {
  sim::SimRobotConfig c;
  c.rtde_port = c.dashboard_port = c.script_port = 0;
  return c;
}

}  // namespace

TEST(SimRobot, UrRtdeProgramProtocol) {
  sim::SimRobot robot(config());
  robot.start();
  Client cl(robot.rtdePort());
  cl.next();
  EXPECT_EQ(cl.s.runtime_state, 1u);
  robot.runProgramText("def rtde_control():\n  textmsg(\"x\")\nend\n");
  ASSERT_TRUE(cl.waitFor([](const ur::RtdeStatePackage& s) { return s.runtime_state == 2; }));
  EXPECT_EQ(cl.s.output_int_register[0], 1);  // ready
  EXPECT_EQ(robot.snapshot().program_name, "rtde_control");
  cl.command(26);  // get step time (non-RT): done + out_double0
  ASSERT_TRUE(cl.waitFor(
      [](const ur::RtdeStatePackage& s) { return s.output_int_register[0] == 2; }));
  EXPECT_DOUBLE_EQ(cl.s.output_double_register[0], 0.008);
  cl.command(0);
  ASSERT_TRUE(cl.waitFor(
      [](const ur::RtdeStatePackage& s) { return s.output_int_register[0] == 1; }));
  // servoJ ramp of joint 1 by 0.2 rad over 1 s, then hold: the model converges to the target.
  JointVector q = robot.snapshot().q, q_end = q;
  q_end[0] += 0.2;
  for (int k = 1; k <= 125; ++k) {
    cl.next();
    q[0] = q_end[0] - 0.2 + 0.2 * k / 125.0;
    cl.servoTo(q);
  }
  for (int k = 0; k < 125; ++k) {
    cl.next();
    cl.servoTo(q_end);
  }
  EXPECT_NEAR(cl.s.actual_q[0], q_end[0], 1e-3);
  EXPECT_NEAR(cl.s.target_qd[0], 0.0, 1e-2);
  // servoStop (16): done; then 255 stops the program.
  cl.command(16, 4.0);
  ASSERT_TRUE(cl.waitFor(
      [](const ur::RtdeStatePackage& s) { return s.output_int_register[0] == 2; }));
  cl.command(0);
  ASSERT_TRUE(cl.waitFor(
      [](const ur::RtdeStatePackage& s) { return s.output_int_register[0] == 1; }));
  cl.command(255);
  ASSERT_TRUE(cl.waitFor([](const ur::RtdeStatePackage& s) { return s.runtime_state == 1; }));
}

TEST(SimRobot, TooLargeServoStepIsAProtectiveStop) {
  sim::SimRobot robot(config());
  robot.start();
  Client cl(robot.rtdePort());
  robot.runProgramText("def rtde_control():\nend\n");
  ASSERT_TRUE(cl.waitFor([](const ur::RtdeStatePackage& s) { return s.runtime_state == 2; }));
  JointVector q = robot.snapshot().q;
  q[2] += 0.1;  // 0.1 rad in 8 ms = 12.5 rad/s > 3.14
  cl.servoTo(q);
  ASSERT_TRUE(cl.waitFor([](const ur::RtdeStatePackage& s) { return s.safety_mode == 3; }));
  EXPECT_TRUE(cl.s.safety_status_bits & (1u << 2));
  ASSERT_TRUE(cl.waitFor([](const ur::RtdeStatePackage& s) { return s.runtime_state == 1; }));
  EXPECT_NE(robot.snapshot().last_event.find("protective stop"), std::string::npos);
}

TEST(SimRobot, WatchdogStopsTheProgram) {
  sim::SimRobot robot(config());
  robot.start();
  Client cl(robot.rtdePort());
  robot.runProgramText("def ftid_servo():\nend\n");
  ASSERT_TRUE(cl.waitFor([](const ur::RtdeStatePackage& s) { return s.runtime_state == 2; }));
  // 5 Hz: 200 ms (25 ticks) without an input package stops the program. This thread feeds it
  // once per tick, so only a 200 ms hold-up of this thread on a loaded machine could fire it.
  cl.command(35, 5.0);
  ASSERT_TRUE(cl.waitFor([&](const ur::RtdeStatePackage& s) {
    cl.command(35, 5.0);
    return s.output_int_register[0] == 2;
  }));
  for (int i = 0; i < 50; ++i) {  // keep feeding for two watchdog periods: still running
    cl.next();
    cl.command(0);
  }
  EXPECT_EQ(cl.s.runtime_state, 2u);
  EXPECT_FALSE(robot.snapshot().watchdog_fired);
  // Stop feeding: stopped after 25 ticks plus the stopping tick (each next() is >= 1 tick).
  ASSERT_TRUE(cl.waitFor([](const ur::RtdeStatePackage& s) { return s.runtime_state == 1; }, 60));
  EXPECT_TRUE(robot.snapshot().watchdog_fired);
}

TEST(SimRobot, TimestampsAdvanceByExactlyOnePeriodAndStartAbove40s) {
  auto cfg = config();
  cfg.model = sim::RobotModel::kUR10e;
  sim::SimRobot robot(cfg);
  robot.start();
  ur::RtdeClient c;
  c.connect("127.0.0.1", robot.rtdePort());
  c.negotiateProtocolVersion();
  c.setupOutputs(500, {"timestamp"});
  c.start();
  ur::RtdeStatePackage s;
  double prev = -1;
  for (int i = 0; i < 200; ++i) {
    ASSERT_EQ(c.tryReceiveState(1000ms, &s), ftid::Status::kOk);
    if (prev > 0) {
      const double steps = (s.timestamp - prev) / 0.002;
      EXPECT_NEAR(steps, std::round(steps), 1e-6);
      EXPECT_EQ(static_cast<std::uint32_t>(std::round(steps)) - 1, s.packages_skipped);
    }
    prev = s.timestamp;
  }
  EXPECT_GT(s.timestamp, 40.0);
}

TEST(SimRobot, PortInUseIsAClearError) {
  sim::SimRobot a(config());
  a.start();
  auto cfg = config();
  cfg.rtde_port = a.rtdePort();
  sim::SimRobot b(cfg);
  try {
    b.start();
    FAIL();
  } catch (const ftid::DriverError& e) {
    EXPECT_NE(std::string(e.what()).find(std::to_string(a.rtdePort())), std::string::npos);
  }
}

TEST(SimRobot, ParseHelpers) {
  EXPECT_EQ(sim::parseRobotModel("UR10e"), sim::RobotModel::kUR10e);
  EXPECT_THROW(sim::parseRobotModel("ur5"), ftid::ConfigError);
  EXPECT_EQ(sim::parseFaultKind("drop"), sim::FaultKind::kDropPackets);
  EXPECT_THROW(sim::parseFaultKind("meteor"), ftid::ConfigError);
}
