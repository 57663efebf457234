// The motion runner streams a Fourier trajectory to the UR simulator over loopback RTDE at
// 125 Hz (UR10/CB3) and 500 Hz (UR10e), and injected faults end cleanly.
//
// Documented bound (docs/robot.md, "Tracking"): with the simulator's servoj model (omega = 20
// rad/s for lookahead 0.1 s / gain 300, velocity feed-forward, one tick of actual_q delay) and
// the trajectory below (peak joint speed ~0.6 rad/s, harmonics at 0.5 and 1 Hz), the recorded
// actual_q stays within kTrackingBound of q_traj(t) at the same robot time; the expected error
// is ~0.01 rad (two ticks of lag at 125 Hz plus the filter error); the bound leaves margin for a
// loaded machine, where a late host thread shows up as lost packages rather than as error.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <thread>

#include "ftid/common/error.hpp"
#include "ftid/drivers/ur/rtde_arm.hpp"
#include "ftid/drivers/ur/rtde_protocol.hpp"
#include "ftid/motion/robot_session.hpp"
#include "ftid/simrobot/sim_robot.hpp"
#include "ftid/trajectory/fourier_trajectory.hpp"

using namespace std::chrono_literals;
using ftid::JointVector;
namespace sim = ftid::simrobot;
namespace motion = ftid::motion;
namespace rtde = ftid::drivers::ur::rtde;

namespace {

constexpr double kTrackingBound = 0.03;  // [rad]

ftid::trajectory::FourierTrajectory makeTrajectory() {
  // Rest-to-rest: sum_l a_il = 0, sum_l l b_il = 0, duration = one base period.
  std::array<std::array<double, 16>, 6> a{}, b{};
  const double A[6] = {0.3, -0.25, 0.2, 0.0, 0.3, -0.3};
  const double B[6] = {0.1, 0.05, -0.1, 0.0, 0.0, 0.1};
  for (int j = 0; j < 6; ++j) {
    a[j][0] = A[j];
    a[j][1] = -A[j];
    b[j][0] = -2.0 * B[j];
    b[j][1] = B[j];
  }
  JointVector q0;
  q0 << 0.1, -1.5, 1.5, -1.6, -1.5, 0.05;
  return ftid::trajectory::FourierTrajectory(q0, 0.5, 2, 2.0, a, b);
}

sim::SimRobotConfig simConfig(sim::RobotModel model) {
  sim::SimRobotConfig c;
  c.model = model;
  c.rtde_port = c.dashboard_port = c.script_port = 0;
  c.thread_priority = 60;  // like a real controller; stays normal without the privilege
  return c;
}

motion::RobotSessionConfig sessionConfig(const sim::SimRobot& s) {
  motion::RobotSessionConfig c;
  c.arm.rtde_port = s.rtdePort();
  c.arm.script_port = s.scriptPort();
  c.motion.approach_velocity = 0.3;
  c.motion.approach_acceleration = 1.0;
  c.motion.settle_time = 0.1;
  return c;
}

// The simulator's state once pred(snapshot) holds, or after 5 s (the last snapshot): a stop is
// awaited as a condition, not guessed from a sleep that a loaded machine can outlast.
template <class Pred>
sim::SimSnapshot snapshotOnce(const sim::SimRobot& s, Pred pred) {
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  sim::SimSnapshot snap = s.snapshot();
  while (!pred(snap) && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(5ms);
    snap = s.snapshot();
  }
  return snap;
}

bool stoppedAndAtRest(const sim::SimSnapshot& snap) {
  return snap.runtime_state != rtde::kRuntimePlaying && !snap.moving;
}

struct HookCounter {
  std::atomic<int> calls{0};
  static void hook(void* ctx, const motion::RecordedTick&) noexcept {
    static_cast<HookCounter*>(ctx)->calls.fetch_add(1, std::memory_order_relaxed);
  }
};

void checkStreaming(sim::RobotModel model, double period) {
  sim::SimRobot s(simConfig(model));
  s.start();
  const auto traj = makeTrajectory();
  motion::EvaluatedTrajectory<ftid::trajectory::FourierTrajectory> src(traj);
  HookCounter counter;
  const auto r = motion::runOnRobot(sessionConfig(s), src, nullptr, &HookCounter::hook, &counter);
  ASSERT_EQ(r.run.status, motion::RunStatus::kCompleted) << r.run.message << " [loop: " << r.run.realtime.describe() << "]";
  EXPECT_DOUBLE_EQ(r.period, period);
  ASSERT_FALSE(r.recording.empty());
  EXPECT_EQ(counter.calls.load(), static_cast<int>(r.recording.size()));
  // Every excitation tick: actual_q vs the trajectory at the same ROBOT time.
  int excite = 0;
  double max_err = 0.0, prev_ts = -1.0, first_excite_ts = -1.0, last_excite_ts = -1.0;
  for (const auto& t : r.recording) {
    if (prev_ts > 0) {
      EXPECT_GT(t.state.timestamp, prev_ts);
    }
    prev_ts = t.state.timestamp;
    if (t.phase != motion::Phase::kExcite || t.t_traj < 0 || t.t_traj > traj.duration()) continue;
    ++excite;
    if (first_excite_ts < 0) first_excite_ts = t.state.timestamp;
    last_excite_ts = t.state.timestamp;
    const JointVector q_ref = traj.evaluate(t.t_traj).q;
    max_err = std::max(max_err, (t.state.q - q_ref).cwiseAbs().maxCoeff());
  }
  // The excitation covered the whole trajectory in robot time. A loaded host may lose a few
  // packages (drain-to-latest skips; the runner aborts beyond lost_time_limit): every tick of the
  // span is either recorded or counted by the runner as lost, not silently missing.
  const int expected = static_cast<int>(traj.duration() / period);
  const int span = static_cast<int>(std::lround((last_excite_ts - first_excite_ts) / period)) + 1;
  EXPECT_GE(span, expected - 2) << "excitation ticks " << excite;
  EXPECT_LE(static_cast<std::uint64_t>(span - excite), r.run.stats.packets_lost)
      << "excitation ticks " << excite << " of " << span;
  EXPECT_LT(max_err, kTrackingBound);
  EXPECT_NEAR(r.run.max_tracking_error, max_err, 1e-12);
  std::printf("model %s: %d excitation ticks, max tracking error %.5f rad, %llu packages lost\n",
              period < 0.005 ? "UR10e" : "UR10", excite, max_err,
              static_cast<unsigned long long>(r.run.stats.packets_lost));
  std::printf("%s", r.run.stats.summary("streaming loop").c_str());
  std::printf("loop thread: %s\n", r.run.realtime.describe().c_str());
  // The program was stopped at the end and the arm rests at the trajectory's final pose.
  const auto snap = snapshotOnce(s, stoppedAndAtRest);
  EXPECT_NE(snap.runtime_state, rtde::kRuntimePlaying);
  EXPECT_FALSE(snap.moving);
  EXPECT_LT((snap.q - traj.evaluate(traj.duration()).q).cwiseAbs().maxCoeff(), 0.005);
}

}  // namespace

TEST(RobotStreaming, Ur10At125Hz) { checkStreaming(sim::RobotModel::kUR10, 0.008); }
TEST(RobotStreaming, Ur10eAt500Hz) { checkStreaming(sim::RobotModel::kUR10e, 0.002); }

// ------------------------------------------------------------------------------------------------
struct FaultCase {
  sim::FaultKind kind;
  int count;
  motion::RunStatus expected;
};

class RobotFault : public ::testing::TestWithParam<FaultCase> {};

TEST_P(RobotFault, EndsStoppedWithMessageAndData) {
  const FaultCase fc = GetParam();
  auto cfg = simConfig(sim::RobotModel::kUR10);
  // Faults fire 1.6 s of controller time after the program starts: during the excitation.
  cfg.scheduled_faults.push_back({1.6, fc.kind, fc.count});
  sim::SimRobot s(cfg);
  s.start();
  const auto traj = makeTrajectory();
  motion::EvaluatedTrajectory<ftid::trajectory::FourierTrajectory> src(traj);
  const auto r = motion::runOnRobot(sessionConfig(s), src);
  EXPECT_EQ(r.run.status, fc.expected) << r.run.message << " [loop: " << r.run.realtime.describe() << "]";
  EXPECT_FALSE(r.run.message.empty());
  std::printf("%s: %s\n", sim::faultKindName(fc.kind), r.run.message.c_str());
  // Data up to the fault is intact: excitation ticks with increasing timestamps and finite q.
  int excite = 0;
  double prev = -1;
  for (const auto& t : r.recording) {
    EXPECT_TRUE(t.state.q.allFinite());
    EXPECT_GT(t.state.timestamp, prev);
    prev = t.state.timestamp;
    if (t.phase == motion::Phase::kExcite) ++excite;
  }
  EXPECT_GT(excite, 10);
  EXPECT_EQ(r.recording.size(), r.run.ticks_recorded);
  // The arm ends stopped (the watchdog covers the disconnect case) and no program runs.
  const auto snap = snapshotOnce(s, stoppedAndAtRest);
  EXPECT_FALSE(snap.moving) << snap.last_event;
  EXPECT_NE(snap.runtime_state, rtde::kRuntimePlaying) << snap.last_event;
}

INSTANTIATE_TEST_SUITE_P(
    Faults, RobotFault,
    ::testing::Values(FaultCase{sim::FaultKind::kProtectiveStop, 0, motion::RunStatus::kProtectiveStop},
                      FaultCase{sim::FaultKind::kProgramStop, 0, motion::RunStatus::kProgramStopped},
                      FaultCase{sim::FaultKind::kDropPackets, 10, motion::RunStatus::kLostPackets},
                      FaultCase{sim::FaultKind::kDisconnect, 0, motion::RunStatus::kConnectionLost},
                      FaultCase{sim::FaultKind::kEmergencyStop, 0, motion::RunStatus::kEmergencyStop}),
    [](const ::testing::TestParamInfo<FaultCase>& p) { return std::string(sim::faultKindName(p.param.kind)); });

// Late packages (a burst after a hold-up) are tolerated when short: drain-to-latest + gap check.
TEST(RobotFaultTolerance, ShortLateBurstIsTolerated) {
  auto cfg = simConfig(sim::RobotModel::kUR10);
  cfg.scheduled_faults.push_back({1.6, sim::FaultKind::kLatePackets, 1});
  sim::SimRobot s(cfg);
  s.start();
  const auto traj = makeTrajectory();
  motion::EvaluatedTrajectory<ftid::trajectory::FourierTrajectory> src(traj);
  const auto r = motion::runOnRobot(sessionConfig(s), src);
  EXPECT_EQ(r.run.status, motion::RunStatus::kCompleted) << r.run.message << " [loop: " << r.run.realtime.describe() << "]";
}

// Two lost packages mid-motion: below the limit; the last-hop check measures the step against
// the robot time since the previous accepted target, so the catch-up step is not rejected.
TEST(RobotFaultTolerance, TwoDroppedPackagesAreTolerated) {
  auto cfg = simConfig(sim::RobotModel::kUR10);
  cfg.scheduled_faults.push_back({1.6, sim::FaultKind::kDropPackets, 2});
  sim::SimRobot s(cfg);
  s.start();
  const auto traj = makeTrajectory();
  motion::EvaluatedTrajectory<ftid::trajectory::FourierTrajectory> src(traj);
  const auto r = motion::runOnRobot(sessionConfig(s), src);
  EXPECT_EQ(r.run.status, motion::RunStatus::kCompleted) << r.run.message << " [loop: " << r.run.realtime.describe() << "]";
  EXPECT_GE(r.run.stats.packets_lost, 2u);
}

// Caller abort (what SIGINT does in `ftid run-trajectory`).
TEST(RobotFaultTolerance, CallerAbortStopsTheArm) {
  sim::SimRobot s(simConfig(sim::RobotModel::kUR10e));
  s.start();
  const auto traj = makeTrajectory();
  motion::EvaluatedTrajectory<ftid::trajectory::FourierTrajectory> src(traj);
  // The flag is raised after 1100 recorded ticks (late in the excitation, ~330 ticks before the
  // end): by the loop's own hook, so where the abort lands does not depend on how promptly a
  // watcher thread is scheduled on a loaded machine.
  struct AbortAfter {
    std::atomic<bool> flag{false};
    std::atomic<int> ticks{0};
    static void hook(void* ctx, const motion::RecordedTick&) noexcept {
      auto* self = static_cast<AbortAfter*>(ctx);
      if (self->ticks.fetch_add(1, std::memory_order_relaxed) + 1 >= 1100) self->flag = true;
    }
  } caller;
  const auto r = motion::runOnRobot(sessionConfig(s), src, &caller.flag, &AbortAfter::hook, &caller);
  EXPECT_EQ(r.run.status, motion::RunStatus::kAborted) << r.run.message << " [loop: " << r.run.realtime.describe() << "]";
  EXPECT_GT(r.recording.size(), 1000u);
  const auto snap = s.snapshot();
  EXPECT_FALSE(snap.moving);
}

// ftid dies or stalls mid-stream: the RTDE watchdog in the servo program stops the arm.
TEST(RobotFaultTolerance, ClientStallTriggersTheWatchdog) {
  sim::SimRobot s(simConfig(sim::RobotModel::kUR10));
  s.start();
  ftid::drivers::ur::RtdeArmConfig ac;
  ac.rtde_port = s.rtdePort();
  ac.script_port = s.scriptPort();
  // 4 Hz (250 ms) instead of the default 10 Hz: this thread is not real-time, and a 100 ms
  // hold-up of it on a loaded machine must not fire the watchdog while it is still feeding.
  ac.watchdog_min_hz = 4.0;
  ftid::drivers::ur::RtdeArm arm(ac);
  arm.connect();
  arm.uploadProgram();
  arm.armWatchdog();
  ftid::drivers::ur::ArmState st;
  ASSERT_EQ(arm.waitForState(1000ms, &st), ftid::Status::kOk);
  arm.resetServoReference(st.q, st.qd);
  JointVector q = st.q;
  for (int k = 0; k < 100; ++k) {  // move joint 1 at 0.25 rad/s for 0.8 s
    ASSERT_EQ(arm.waitForState(1000ms, &st), ftid::Status::kOk);
    q[0] += std::min(0.25, 0.01 * k) * arm.period();
    ASSERT_EQ(arm.sendServoTarget(q), ftid::Status::kOk);
  }
  EXPECT_TRUE(s.snapshot().moving);
  EXPECT_FALSE(s.snapshot().watchdog_fired);
  // Stop sending: the watchdog fires after 1/4 Hz and the arm is brought to rest.
  const auto snap = snapshotOnce(
      s, [](const sim::SimSnapshot& x) { return x.watchdog_fired && stoppedAndAtRest(x); });
  EXPECT_TRUE(snap.watchdog_fired) << snap.last_event;
  EXPECT_NE(snap.runtime_state, rtde::kRuntimePlaying);
  EXPECT_FALSE(snap.moving);
}

// Issue 14, "Links": the calling (non-real-time) thread stalls for 150 ms between the program
// upload and the loop (here in the pre-motion check; in the field: load, page faults, a long
// check). The servo program's watchdog (10 Hz: 0.1 s) is armed by the loop's first cycles, so the
// stall cannot fire it, and the backlog it leaves is not counted as lost packages.
TEST(RobotFaultTolerance, CallerStallBeforeTheLoopDoesNotEndTheRun) {
  sim::SimRobot s(simConfig(sim::RobotModel::kUR10));
  s.start();
  const auto traj = makeTrajectory();
  motion::EvaluatedTrajectory<ftid::trajectory::FourierTrajectory> src(traj);
  auto cfg = sessionConfig(s);
  int stalls = 0;
  cfg.motion.preflight = [&](const motion::PlannedMotion&) {
    ++stalls;
    std::this_thread::sleep_for(150ms);
    return std::string();
  };
  const auto r = motion::runOnRobot(cfg, src);
  EXPECT_EQ(stalls, 1);
  EXPECT_EQ(r.run.status, motion::RunStatus::kCompleted) << r.run.message << " [loop: " << r.run.realtime.describe() << "]";
  EXPECT_FALSE(s.snapshot().watchdog_fired) << s.snapshot().last_event;
  std::size_t arming_ticks = 0;  // recorded ticks before the first servo target
  while (arming_ticks < r.recording.size() && !r.recording[arming_ticks].q_command.allFinite()) ++arming_ticks;
  EXPECT_LT(arming_ticks, 63u);  // within watchdog_arm_timeout
  std::printf("watchdog armed by the loop after %zu ticks\n", arming_ticks);
}

// ...and the watchdog the loop armed does guard the run: a 300 ms stall of the loop thread itself
// (in its hook, mid-excitation) fires it, the program stops and the arm is brought to rest.
TEST(RobotFaultTolerance, LoopStallFiresTheWatchdogTheLoopArmed) {
  sim::SimRobot s(simConfig(sim::RobotModel::kUR10));
  s.start();
  const auto traj = makeTrajectory();
  motion::EvaluatedTrajectory<ftid::trajectory::FourierTrajectory> src(traj);
  struct StallOnce {
    bool done = false;
    static void hook(void* ctx, const motion::RecordedTick& t) noexcept {
      auto* self = static_cast<StallOnce*>(ctx);
      if (!self->done && t.phase == motion::Phase::kExcite && t.t_traj > 0.5) {
        self->done = true;
        std::this_thread::sleep_for(300ms);
      }
    }
  } stall;
  const auto r = motion::runOnRobot(sessionConfig(s), src, nullptr, &StallOnce::hook, &stall);
  EXPECT_TRUE(stall.done);
  EXPECT_NE(r.run.status, motion::RunStatus::kCompleted) << r.run.message;
  const auto snap = snapshotOnce(s, stoppedAndAtRest);
  EXPECT_TRUE(snap.watchdog_fired) << snap.last_event << " / " << r.run.message;
  EXPECT_FALSE(snap.moving);
}

// The last hop refuses a non-finite target and the run ends with the arm held and stopped.
TEST(RobotFaultTolerance, NonFiniteTargetIsNeverSent) {
  sim::SimRobot s(simConfig(sim::RobotModel::kUR10));
  s.start();
  struct BadTrajectory final : motion::JointTrajectorySource {
    JointVector q0;
    bool sample(double t, JointVector* q) const noexcept override {
      *q = q0;
      if (t > 0.3) (*q)[2] = std::nan("");
      return true;
    }
    double duration() const noexcept override { return 1.0; }
  } bad;
  bad.q0 << 0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0;
  const auto r = motion::runOnRobot(sessionConfig(s), bad);
  EXPECT_EQ(r.run.status, motion::RunStatus::kTargetRejected) << r.run.message << " [loop: " << r.run.realtime.describe() << "]";
  const auto snap = s.snapshot();
  EXPECT_TRUE(snap.q.allFinite());
  EXPECT_EQ(snap.safety_mode, rtde::kSafetyModeNormal);  // the controller never saw the NaN
  EXPECT_FALSE(snap.moving);
}

// Not ready: protective stop before the run -> nothing moves, clear message.
TEST(RobotFaultTolerance, NotReadyWhenProtectiveStopped) {
  sim::SimRobot s(simConfig(sim::RobotModel::kUR10));
  s.start();
  s.inject(sim::FaultKind::kProtectiveStop);
  const auto traj = makeTrajectory();
  motion::EvaluatedTrajectory<ftid::trajectory::FourierTrajectory> src(traj);
  ftid::drivers::ur::RtdeArmConfig ac;
  ac.rtde_port = s.rtdePort();
  ac.script_port = s.scriptPort();
  ac.program_start_timeout = 500ms;
  ftid::drivers::ur::RtdeArm arm(ac);
  arm.connect();
  try {
    arm.uploadProgram();
    FAIL() << "the program must not start in a protective stop";
  } catch (const ftid::DriverError& e) {
    EXPECT_NE(std::string(e.what()).find("PROTECTIVE_STOP"), std::string::npos) << e.what();
  }
}
