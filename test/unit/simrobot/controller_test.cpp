// The socket-free controller model (controller.hpp), driven tick by tick. Expectations come from
// outside the model: the continuous-time transfer function of the documented tracking law,
// constant-deceleration kinematics, the textbook trapezoidal profile, UR's watchdog rule in
// controller time, and UR's register protocol (servo_program.hpp, ur-interface-notes §3.4).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "ftid/drivers/ur/rtde_protocol.hpp"
#include "ftid/drivers/ur/servo_program.hpp"
#include "ftid/simrobot/controller.hpp"

using ftid::JointVector;
namespace sim = ftid::simrobot;
namespace ur = ftid::drivers::ur;
namespace rtde = ftid::drivers::ur::rtde;

namespace {

constexpr double kPi = 3.14159265358979323846;

// A client of the register protocol at offset o, writing registers directly.
struct Driver {
  sim::Controller& k;
  int o = 0;
  void command(std::int32_t cmd, double arg = 0.0) {
    k.writeInputDouble(o, arg);
    k.writeInputInt(o, cmd);
  }
  void servo(const JointVector& q, double t = 0.0, double lookahead = 0.1, double gain = 300.0) {
    for (int i = 0; i < 6; ++i) k.writeInputDouble(o + i, q[i]);
    k.writeInputDouble(o + 8, t > 0 ? t : k.period());
    k.writeInputDouble(o + 9, lookahead);
    k.writeInputDouble(o + 10, gain);
    k.writeInputInt(o, ur::kCmdServoJ);
  }
  std::int32_t scriptState() const { return k.registers().out_int[static_cast<std::size_t>(o)]; }
};

sim::SimRobotConfig ur10() { return sim::SimRobotConfig{}; }

bool playing(const sim::Controller& k) { return k.runtimeState() == rtde::kRuntimePlaying; }

}  // namespace

TEST(SimController, RecognisesProgramsAndTheirRegisterOffset) {
  sim::Controller k(ur10());
  EXPECT_EQ(k.runtimeState(), rtde::kRuntimeStopped);
  k.loadProgram("def ftid_servo():\n  sync()\nend\n");
  EXPECT_TRUE(playing(k));
  EXPECT_EQ(k.programKind(), sim::ProgramKind::kFtid);
  EXPECT_EQ(k.registerOffset(), 0);
  EXPECT_EQ(k.registers().out_int[0], ur::kScriptReady);

  sim::Controller u(ur10());
  u.loadProgram("def rtde_control():\n  global reg_offset_int = # int register offset\n24\nend\n");
  EXPECT_EQ(u.programKind(), sim::ProgramKind::kUrRtde);
  ASSERT_EQ(u.registerOffset(), 24);
  EXPECT_EQ(u.registers().out_int[24], ur::kScriptReady);
  EXPECT_EQ(u.registers().out_int[0], 0);
  // ur_rtde's GET_STEPTIME (26) at the upper offset: the controller period, then "done".
  Driver d{u, 24};
  d.command(26);
  u.tick();
  EXPECT_EQ(d.scriptState(), ur::kScriptDone);
  EXPECT_DOUBLE_EQ(u.registers().out_double[24], 0.008);
  d.command(ur::kCmdNone);
  u.tick();
  EXPECT_EQ(d.scriptState(), ur::kScriptReady);
  // Another ur_rtde real-time command (speedJ, 9) is acknowledged "ready", never "done".
  d.command(9);
  u.tick();
  EXPECT_EQ(d.scriptState(), ur::kScriptReady);

  // Any other program just plays; its registers are not interpreted.
  sim::Controller other(ur10());
  other.loadProgram("def my_prog():\n  movej([0,0,0,0,0,0])\nend\n");
  EXPECT_TRUE(playing(other));
  EXPECT_EQ(other.programKind(), sim::ProgramKind::kOther);
  Driver od{other};
  od.command(ur::kCmdStopScript);
  other.tick();
  EXPECT_TRUE(playing(other));
  EXPECT_EQ(od.scriptState(), 0);
  // A text without a program is ignored.
  sim::Controller none(ur10());
  none.loadProgram("textmsg(\"hello\")\n");
  EXPECT_EQ(none.programKind(), sim::ProgramKind::kNone);
  EXPECT_EQ(none.runtimeState(), rtde::kRuntimeStopped);
}

TEST(SimController, NonRealtimeCommandsRunOnceUntilCleared) {
  sim::Controller k(ur10());
  k.loadProgram("def ftid_servo():\nend\n");
  Driver d{k};
  d.command(ur::kCmdStopScript);  // 255: done, and the program stops (STOPPING, then STOPPED)
  k.tick();
  EXPECT_EQ(d.scriptState(), ur::kScriptDone);
  EXPECT_EQ(k.runtimeState(), rtde::kRuntimeStopping);
  k.tick();
  EXPECT_EQ(k.runtimeState(), rtde::kRuntimeStopping);
  k.tick();
  EXPECT_EQ(k.runtimeState(), rtde::kRuntimeStopped);
  // play restarts the loaded program.
  EXPECT_TRUE(k.play());
  EXPECT_TRUE(playing(k));
}

TEST(SimController, ServoJFollowsASineWithTheTrackingLawsError) {
  // Tracking law (docs/robot.md §4.1): q'' = w^2 (r - q) + 2 w (r' - q'), w = 2 / L sqrt(K / 300)
  // = 20 rad/s for L = 0.1 s, K = 300. Its error transfer function is E/R = s^2 / (s + w)^2, so a
  // sine r = A sin(W t) is followed with an error of amplitude A W^2 / (W^2 + w^2) once the
  // transient (time constant 1/w = 50 ms) has died out.
  auto cfg = ur10();
  sim::Controller k(cfg);
  k.loadProgram("def ftid_servo():\nend\n");
  Driver d{k};
  const double dt = k.period(), A = 0.2, W = 2.0 * kPi * 0.5, w = 20.0;
  const JointVector q0 = cfg.q0;
  const double expected = A * W * W / (W * W + w * w);  // 4.82 mrad
  double max_err = 0.0, max_q = -1e9, min_q = 1e9;
  for (int n = 1; n <= 750; ++n) {  // 6 s at 125 Hz
    const double r = q0[0] + A * std::sin(W * n * dt);
    JointVector target = q0;
    target[0] = r;
    d.servo(target);
    k.tick();
    ASSERT_TRUE(playing(k)) << k.lastEvent();
    if (n * dt > 2.0) {
      // actual_q of tick n is the state at the instant the target of tick n was applied.
      max_err = std::max(max_err, std::abs(k.actualQ()[0] - r));
      max_q = std::max(max_q, k.actualQ()[0]);
      min_q = std::min(min_q, k.actualQ()[0]);
    }
    for (int j = 1; j < 6; ++j) ASSERT_NEAR(k.motion().q()[j], q0[j], 1e-12);
  }
  EXPECT_NEAR(max_err, expected, 0.25 * expected) << "max error " << max_err << " rad";
  // |Q/R| = w sqrt(w^2 + 4 W^2) / (w^2 + W^2) = 1.023: the amplitude of the motion.
  const double gain = w * std::sqrt(w * w + 4 * W * W) / (w * w + W * W);
  EXPECT_NEAR(0.5 * (max_q - min_q), A * gain, 0.01 * A);
  EXPECT_EQ(k.servoCommands(), 750u);
}

TEST(SimController, ServoHoldSettlesOnTheLastTarget) {
  sim::Controller k(ur10());
  k.loadProgram("def ftid_servo():\nend\n");
  Driver d{k};
  JointVector q = k.motion().q();
  const JointVector q_end = q + (JointVector() << 0.2, -0.1, 0.15, 0.0, 0.3, -0.25).finished();
  const JointVector start = q;
  for (int n = 1; n <= 125; ++n) {  // a 1 s ramp
    q = start + (q_end - start) * (n / 125.0);
    d.servo(q);
    k.tick();
  }
  for (int n = 0; n < 125; ++n) {  // then hold for 1 s (20 time constants)
    d.servo(q_end);
    k.tick();
  }
  EXPECT_LT((k.motion().q() - q_end).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LT(k.motion().qd().cwiseAbs().maxCoeff(), 1e-5);
  EXPECT_TRUE(k.motion().servoActive());
}

namespace {
// Servo joint 1 at a constant speed v until it moves steadily; returns the driver's last target.
JointVector cruise(sim::Controller& k, Driver& d, double v, int ticks) {
  JointVector q = k.motion().q();
  for (int n = 0; n < ticks; ++n) {
    q[0] += v * k.period();
    d.servo(q);
    k.tick();
  }
  return q;
}

// After a stop: every joint decelerates at no more than `decel` until it is at rest, within the
// time v / decel of constant-deceleration kinematics (plus one tick), over the distance
// v^2 / (2 decel) (plus one tick of motion). With `d`, the client keeps streaming servo targets
// (a stopped program ignores them).
void expectStopsAt(sim::Controller& k, Driver* d, const JointVector& held_target, double v, double decel) {
  const double dt = k.period();
  const double q_start = k.motion().q()[0];
  double qd_prev = k.motion().qd()[0];
  ASSERT_NEAR(qd_prev, v, 1e-6);
  const int limit = static_cast<int>(std::ceil(v / decel / dt)) + 1;
  int n = 0;
  for (; n < limit + 20 && k.motion().qd().cwiseAbs().maxCoeff() > 1e-9; ++n) {
    if (d) d->servo(held_target);
    k.tick();
    const double qd = k.motion().qd()[0];
    EXPECT_LE(std::abs(qd - qd_prev), decel * dt * (1 + 1e-9)) << "tick " << n;
    qd_prev = qd;
  }
  EXPECT_LE(n, limit);
  EXPECT_GE(n, limit - 2);
  EXPECT_LE(k.motion().qd().cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_NEAR(k.motion().q()[0] - q_start, v * v / (2 * decel), 0.5 * decel * dt * dt);
  for (int i = 0; i < 10; ++i) {  // and it stays there
    if (d) d->servo(held_target);
    k.tick();
  }
  EXPECT_LE(k.motion().qd().cwiseAbs().maxCoeff(), 1e-9);
}
}  // namespace

TEST(SimController, ProtectiveStopStopsTheProgramAndTheArm) {
  sim::Controller k(ur10());
  k.loadProgram("def ftid_servo():\nend\n");
  Driver d{k};
  const JointVector last = cruise(k, d, 1.0, 125);
  k.inject(sim::FaultKind::kProtectiveStop, 1);
  EXPECT_EQ(k.safetyMode(), rtde::kSafetyModeProtectiveStop);
  EXPECT_EQ(k.safetyStatusBits(), rtde::kSafetyStatusProtectiveStopped | rtde::kSafetyStatusStoppedDueToSafety);
  EXPECT_EQ(k.runtimeState(), rtde::kRuntimeStopping);
  EXPECT_FALSE(k.motion().servoActive());
  expectStopsAt(k, &d, last, 1.0, 10.0);
  EXPECT_EQ(k.runtimeState(), rtde::kRuntimeStopped);
  // No program starts while protective-stopped; unlocking allows it again.
  k.loadProgram("def ftid_servo():\nend\n");
  EXPECT_EQ(k.runtimeState(), rtde::kRuntimeStopped);
  EXPECT_NE(k.lastEvent().find("not started"), std::string::npos);
  k.unlockProtectiveStop();
  EXPECT_TRUE(k.play());
}

TEST(SimController, EmergencyStopPowersOffAfterStopping) {
  sim::Controller k(ur10());
  k.loadProgram("def ftid_servo():\nend\n");
  Driver d{k};
  const JointVector last = cruise(k, d, -0.8, 100);
  k.inject(sim::FaultKind::kEmergencyStop, 1);
  EXPECT_EQ(k.safetyMode(), rtde::kSafetyModeRobotEmergencyStop);
  EXPECT_EQ(k.robotMode(), rtde::kRobotModePowerOff);
  // Deceleration sign: joint 1 moves at -0.8 rad/s.
  const double dt = k.period();
  double qd_prev = k.motion().qd()[0];
  int n = 0;
  while (std::abs(k.motion().qd()[0]) > 1e-9 && n < 200) {
    d.servo(last);
    k.tick();
    EXPECT_LE(std::abs(k.motion().qd()[0] - qd_prev), 10.0 * dt * (1 + 1e-9));
    qd_prev = k.motion().qd()[0];
    ++n;
  }
  EXPECT_LE(n, static_cast<int>(std::ceil(0.8 / 10.0 / dt)) + 1);
  EXPECT_FALSE(k.play());
}

TEST(SimController, ServoStopUsesItsDeceleration) {
  sim::Controller k(ur10());
  k.loadProgram("def ftid_servo():\nend\n");
  Driver d{k};
  const JointVector last = cruise(k, d, 1.2, 125);
  d.command(ur::kCmdServoStop, 4.0);  // 16 with 4 rad/s^2, then no more targets
  expectStopsAt(k, nullptr, last, 1.2, 4.0);
  EXPECT_EQ(d.scriptState(), ur::kScriptDone);
  EXPECT_TRUE(playing(k));  // servoStop ends following, not the program
}

TEST(SimController, TargetsOutsideLimitsOrNonFiniteAreProtectiveStops) {
  auto cfg = ur10();
  cfg.position_upper[2] = cfg.q0[2] + 0.001;
  for (double bad : {cfg.q0[2] + 0.002, std::nan("")}) {
    sim::Controller k(cfg);
    k.loadProgram("def ftid_servo():\nend\n");
    Driver d{k};
    JointVector q = cfg.q0;
    q[2] = bad;
    d.servo(q);
    k.tick();
    EXPECT_EQ(k.safetyMode(), rtde::kSafetyModeProtectiveStop) << bad;
    EXPECT_EQ(k.motion().q(), cfg.q0);
  }
  // A step the joint cannot make in one period at its speed limit (UR10 elbow: 3.14 rad/s).
  sim::Controller k(ur10());
  k.loadProgram("def ftid_servo():\nend\n");
  Driver d{k};
  JointVector q = k.motion().q();
  q[2] += 3.2 * k.period();
  d.servo(q);
  k.tick();
  EXPECT_EQ(k.safetyMode(), rtde::kSafetyModeProtectiveStop);
  EXPECT_NE(k.lastEvent().find("protective stop"), std::string::npos);
}

TEST(SimController, WatchdogExpiresAfterItsPeriodOfControllerTime) {
  // UR's rtde_set_watchdog(var, f, "stop"): the program stops at the first controller tick at
  // which more than 1/f seconds have passed since the watched input was last written.
  sim::Controller k(ur10());
  k.loadProgram("def ftid_servo():\nend\n");
  Driver d{k};
  const double f = 4.5;  // 1/f = 0.222 s = 27.8 ticks
  d.command(ur::kCmdSetWatchdog, f);
  k.tick();
  ASSERT_EQ(d.scriptState(), ur::kScriptDone);
  EXPECT_TRUE(k.watchdogArmed());
  for (int n = 0; n < 100; ++n) {  // fed every tick for 0.8 s: keeps playing
    d.command(ur::kCmdNone);
    k.tick();
  }
  ASSERT_TRUE(playing(k));
  d.command(ur::kCmdNone);
  const double t_last_write = k.timestamp();
  double t_prev = t_last_write;
  while (playing(k) && k.timestamp() - t_last_write < 1.0) {
    t_prev = k.timestamp();
    k.tick();
  }
  EXPECT_FALSE(playing(k));
  EXPECT_TRUE(k.watchdogFired());
  EXPECT_GT(k.timestamp() - t_last_write, 1.0 / f);
  EXPECT_LE(t_prev - t_last_write, 1.0 / f);
  EXPECT_NE(k.lastEvent().find("watchdog"), std::string::npos);
  // A restart disarms it.
  EXPECT_TRUE(k.play());
  EXPECT_FALSE(k.watchdogArmed());
  EXPECT_FALSE(k.watchdogFired());
}

TEST(SimController, MoveJIsASynchronisedTrapezoid) {
  // Largest displacement D = 0.5 rad at v = 0.8 rad/s, a = 2 rad/s^2: accelerate for v/a = 0.4 s,
  // cruise, decelerate; duration D/v + v/a = 1.025 s. Every joint follows the same fraction.
  sim::Controller k(ur10());
  k.loadProgram("def ftid_servo():\nend\n");
  Driver d{k};
  const JointVector start = k.motion().q();
  const JointVector delta = (JointVector() << 0.0, 0.5, -0.25, 0.1, 0.0, 0.0).finished();
  for (int i = 0; i < 6; ++i) k.writeInputDouble(i, start[i] + delta[i]);
  k.writeInputDouble(6, 0.8);
  k.writeInputDouble(7, 2.0);
  k.writeInputInt(0, ur::kCmdMoveJ);
  const double dt = k.period();
  double peak_qd = 0.0;
  int n = 0;
  JointVector qd_prev = JointVector::Zero();
  while (n < 400) {
    k.tick();
    ++n;
    const JointVector moved = k.motion().q() - start;
    EXPECT_NEAR(moved[2], -0.5 * moved[1], 1e-12);
    EXPECT_NEAR(moved[3], 0.2 * moved[1], 1e-12);
    peak_qd = std::max(peak_qd, std::abs(k.motion().qd()[1]));
    if (d.scriptState() == ur::kScriptDone) break;
    EXPECT_EQ(d.scriptState(), 0) << "busy while moving";
    EXPECT_LE(std::abs(k.motion().qd()[1] - qd_prev[1]), 2.0 * dt * (1 + 1e-6) + 1e-12) << n;
    qd_prev = k.motion().qd();
  }
  EXPECT_NEAR(n * dt, 0.5 / 0.8 + 0.8 / 2.0, dt);
  EXPECT_LT((k.motion().q() - (start + delta)).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NEAR(peak_qd, 0.8, 1e-9);
}

TEST(SimController, InjectedClockAndPackageFaults) {
  sim::Controller k(ur10());
  k.tick();
  const double t = k.timestamp();
  EXPECT_DOUBLE_EQ(t, 50.008);
  k.inject(sim::FaultKind::kStallTicks, 3);
  for (int i = 0; i < 3; ++i) {
    const auto r = k.tick();
    EXPECT_FALSE(r.advanced);
    EXPECT_EQ(k.timestamp(), t);
  }
  EXPECT_TRUE(k.tick().advanced);
  EXPECT_DOUBLE_EQ(k.timestamp(), t + 0.008);
  k.inject(sim::FaultKind::kDropPackets, 2);
  k.inject(sim::FaultKind::kLatePackets, 1);
  auto r = k.tick();
  EXPECT_TRUE(r.drop && r.late);
  r = k.tick();
  EXPECT_TRUE(r.drop && !r.late);
  r = k.tick();
  EXPECT_TRUE(!r.drop && !r.late);
  EXPECT_FALSE(k.takeDisconnectRequest());
  k.inject(sim::FaultKind::kDisconnect, 1);
  EXPECT_TRUE(k.takeDisconnectRequest());
  EXPECT_FALSE(k.takeDisconnectRequest());
}

TEST(SimController, ScheduledFaultFiresAfterTheFirstProgramStart) {
  auto cfg = ur10();
  cfg.scheduled_faults.push_back({0.1, sim::FaultKind::kProgramStop, 1});
  sim::Controller k(cfg);
  for (int i = 0; i < 50; ++i) k.tick();  // no program yet: the schedule has not started
  k.loadProgram("def ftid_servo():\nend\n");
  const double t_start = k.timestamp();
  while (playing(k) && k.timestamp() - t_start < 1.0) k.tick();
  EXPECT_NEAR(k.timestamp() - t_start, 0.1, k.period() + 1e-9);
}
