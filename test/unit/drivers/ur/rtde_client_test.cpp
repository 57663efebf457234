// RtdeClient / DashboardClient against the simulator on loopback (ephemeral ports).
// CTest runs these in parallel with other tests on a loaded 2-core machine: waits for the
// simulator are conditions polled up to a generous deadline, never a fixed sleep.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <thread>

#include "ftid/common/error.hpp"
#include "ftid/drivers/ur/dashboard_client.hpp"
#include "ftid/drivers/ur/rtde_client.hpp"
#include "ftid/simrobot/sim_robot.hpp"

using namespace ftid::drivers::ur;
using namespace std::chrono_literals;

namespace {
ftid::simrobot::SimRobotConfig simConfig(ftid::simrobot::RobotModel model) {
  ftid::simrobot::SimRobotConfig c;
  c.model = model;
  c.rtde_port = c.dashboard_port = c.script_port = 0;
  return c;
}

// How long a test waits for the next package. The tests check content, order and skips, not
// latency: the bound only has to outlast a scheduling hiccup of a loaded machine.
constexpr auto kNextPackage = 1000ms;

// Polls pred every 2 ms until it holds (true) or 5 s have passed (false).
template <class Pred>
bool eventually(Pred pred) {
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (!pred()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(2ms);
  }
  return true;
}
}  // namespace

TEST(RtdeClient, HandshakeAndStreamingCb3) {
  ftid::simrobot::SimRobot sim(simConfig(ftid::simrobot::RobotModel::kUR10));
  sim.start();
  RtdeClient c;
  c.connect("127.0.0.1", sim.rtdePort(), 2000ms);
  ASSERT_TRUE(c.negotiateProtocolVersion());
  EXPECT_EQ(c.protocolVersion(), 2);
  const auto v = c.controllerVersion();
  EXPECT_EQ(v.toString(), "3.15.8.106339");
  const auto types = c.setupOutputs(125.0, RtdeClient::defaultOutputNames());
  ASSERT_EQ(types.size(), RtdeClient::defaultOutputNames().size());
  EXPECT_EQ(types[0], "DOUBLE");
  EXPECT_EQ(types[1], "VECTOR6D");
  c.start();
  RtdeStatePackage s;
  double last = -1;
  int gaps = 0;
  for (int i = 0; i < 50; ++i) {
    ASSERT_EQ(c.tryReceiveState(kNextPackage, &s), ftid::Status::kOk) << c.lastError();
    if (last > 0 && std::abs(s.timestamp - last - 0.008 * (1 + s.packages_skipped)) > 1e-9) ++gaps;
    last = s.timestamp;
  }
  EXPECT_EQ(gaps, 0);
  EXPECT_GT(s.timestamp, 40.0);
  EXPECT_EQ(s.robot_mode, rtde::kRobotModeRunning);
  EXPECT_EQ(s.safety_mode, rtde::kSafetyModeNormal);
  EXPECT_EQ(s.runtime_state, rtde::kRuntimeStopped);
  EXPECT_NEAR(s.actual_q[1], -1.5708, 1e-12);
  EXPECT_TRUE(s.present & kFieldActualTcpPose);
  EXPECT_TRUE(s.output_int_present & 1u);
  c.pause();
  c.disconnect();
}

TEST(RtdeClient, ESeriesDecimationAndDrainToLatest) {
  ftid::simrobot::SimRobot sim(simConfig(ftid::simrobot::RobotModel::kUR10e));
  sim.start();
  RtdeClient c;
  c.connect("127.0.0.1", sim.rtdePort());
  ASSERT_TRUE(c.negotiateProtocolVersion());
  EXPECT_EQ(c.controllerVersion().major, 5u);
  c.setupOutputs(250.0, {"timestamp", "actual_q"});  // floor(500/250) = every 2nd tick
  c.start();
  RtdeStatePackage a, b;
  ASSERT_EQ(c.tryReceiveState(kNextPackage, &a), ftid::Status::kOk);
  ASSERT_EQ(c.tryReceiveState(kNextPackage, &b), ftid::Status::kOk);
  const double steps = std::round((b.timestamp - a.timestamp) / 0.004);
  EXPECT_GE(steps, 1.0);
  EXPECT_NEAR(b.timestamp - a.timestamp, steps * 0.004, 1e-9);
  // Let 15 packages pile up unread (counted by the simulator, not guessed from a sleep).
  const std::uint64_t sent = sim.snapshot().packages_sent;
  ASSERT_TRUE(eventually([&] { return sim.snapshot().packages_sent >= sent + 15; }));
  ASSERT_EQ(c.tryReceiveState(kNextPackage, &b), ftid::Status::kOk);
  EXPECT_GT(b.packages_skipped, 3u);
  EXPECT_GT(c.stats().packages_skipped, 3u);
}

TEST(RtdeClient, NotFoundOutputsThrowWithNames) {
  ftid::simrobot::SimRobot sim(simConfig(ftid::simrobot::RobotModel::kUR10));
  sim.start();
  RtdeClient c;
  c.connect("127.0.0.1", sim.rtdePort());
  c.negotiateProtocolVersion();
  try {
    c.setupOutputs(125.0, {"timestamp", "no_such_variable"});
    FAIL() << "expected DriverError";
  } catch (const ftid::DriverError& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_variable"), std::string::npos) << e.what();
  }
}

TEST(RtdeClient, InputOwnershipIsPerConnection) {
  ftid::simrobot::SimRobot sim(simConfig(ftid::simrobot::RobotModel::kUR10));
  sim.start();
  RtdeClient a, b;
  a.connect("127.0.0.1", sim.rtdePort());
  a.negotiateProtocolVersion();
  const auto r1 = a.setupInputs({"input_int_register_0", "input_double_register_0"});
  const auto r2 = a.setupInputs({"input_int_register_0"});  // same connection: allowed, next id
  EXPECT_EQ(r1.id, 1);
  EXPECT_EQ(r2.id, 2);
  b.connect("127.0.0.1", sim.rtdePort());
  b.negotiateProtocolVersion();
  try {
    b.setupInputs({"input_int_register_0"});
    FAIL() << "expected IN_USE";
  } catch (const ftid::DriverError& e) {
    EXPECT_NE(std::string(e.what()).find("IN_USE"), std::string::npos) << e.what();
  }
  EXPECT_EQ(b.setupInputs({"input_int_register_24"}).id, 1);
  a.disconnect();  // releases ownership once the controller has closed a's connection
  ASSERT_TRUE(eventually([&] { return sim.snapshot().rtde_connections == 1; }));
  EXPECT_EQ(b.setupInputs({"input_int_register_0"}).id, 2);
}

TEST(RtdeClient, ConnectionClosedIsAFault) {
  ftid::simrobot::SimRobot sim(simConfig(ftid::simrobot::RobotModel::kUR10));
  sim.start();
  RtdeClient c;
  c.connect("127.0.0.1", sim.rtdePort());
  c.negotiateProtocolVersion();
  c.setupOutputs(125.0, {"timestamp"});
  c.start();
  RtdeStatePackage s;
  ASSERT_EQ(c.tryReceiveState(kNextPackage, &s), ftid::Status::kOk);
  sim.inject(ftid::simrobot::FaultKind::kDisconnect);
  ftid::Status st = ftid::Status::kOk;
  for (int i = 0; i < 100 && st == ftid::Status::kOk; ++i) st = c.tryReceiveState(kNextPackage, &s);
  EXPECT_EQ(st, ftid::Status::kFault);
}

TEST(RtdeClient, TimeoutWhenTheClockStalls) {
  ftid::simrobot::SimRobot sim(simConfig(ftid::simrobot::RobotModel::kUR10));
  sim.start();
  RtdeClient c;
  c.connect("127.0.0.1", sim.rtdePort());
  c.negotiateProtocolVersion();
  c.setupOutputs(125.0, {"timestamp"});
  c.start();
  RtdeStatePackage s;
  ASSERT_EQ(c.tryReceiveState(kNextPackage, &s), ftid::Status::kOk);
  // 2 s without packages: far longer than this thread can be held up before it waits below.
  sim.inject(ftid::simrobot::FaultKind::kStallTicks, 250);
  std::this_thread::sleep_for(20ms);
  ftid::Status st = ftid::Status::kOk;
  for (int i = 0; i < 10 && st == ftid::Status::kOk; ++i) st = c.tryReceiveState(12ms, &s);
  EXPECT_EQ(st, ftid::Status::kTimeout);
  EXPECT_GE(c.stats().timeouts, 1u);
}

TEST(DashboardClient, ExactReplies) {
  ftid::simrobot::SimRobot sim(simConfig(ftid::simrobot::RobotModel::kUR10e));
  sim.start();
  DashboardClient d;
  d.connect("127.0.0.1", sim.dashboardPort());
  EXPECT_EQ(d.robotMode(), "RUNNING");
  EXPECT_EQ(d.safetyMode(), "NORMAL");
  EXPECT_EQ(d.polyscopeVersion(), "URSoftware 5.11.1.108318 (Mar 22 2021)");
  EXPECT_EQ(d.command("get serial number"), "20185500000");
  EXPECT_FALSE(d.isProgramRunning());
  d.stop();
  EXPECT_EQ(d.command("bogus"), "could not understand: 'bogus'");
  EXPECT_EQ(d.command("sim protective_stop"), "Sim: injected protective_stop");
  std::this_thread::sleep_for(30ms);
  EXPECT_EQ(d.safetyMode(), "PROTECTIVE_STOP");
  d.unlockProtectiveStop();
  std::this_thread::sleep_for(10ms);
  EXPECT_EQ(d.safetyMode(), "NORMAL");
  d.powerOff();
  EXPECT_EQ(d.robotMode(), "POWER_OFF");
  d.powerOn();
  EXPECT_EQ(d.robotMode(), "IDLE");
  d.brakeRelease();
  EXPECT_EQ(d.robotMode(), "RUNNING");
}
