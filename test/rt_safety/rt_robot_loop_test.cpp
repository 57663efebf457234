// Zero allocations in the robot loop: the MotionRunner cycle (executor + checks + trajectory +
// last-hop check) over thousands of cycles against a fake arm, and the RTDE client's streaming
// calls against the simulator, counted on the thread that runs them.
#include <gtest/gtest.h>

#include <optional>
#include <thread>

#include "alloc_controls.hpp"
#include "alloc_counter.hpp"
#include "ftid/drivers/ur/rtde_arm.hpp"
#include "ftid/drivers/ur/rtde_client.hpp"
#include "ftid/drivers/ur/rtde_protocol.hpp"
#include "ftid/motion/motion_runner.hpp"
#include "../support/fake_arm.hpp"
#include "ftid/rt/mailbox.hpp"
#include "ftid/rt/spsc_queue.hpp"
#include "ftid/simrobot/sim_robot.hpp"
#include "ftid/trajectory/fourier_trajectory.hpp"

using namespace std::chrono_literals;
using ftid::JointVector;
using ftid::Status;
namespace ur = ftid::drivers::ur;

namespace {

/// The shared fake controller (test/support/fake_arm.hpp) at a fixed start pose, counting
/// allocations on the loop thread from its first call there until the run drains (the fake's
/// kFault after the stop); every 500th wait there times out (a missed cycle).
class FakeArm final : public ftid::test::FakeArm {
 public:
  explicit FakeArm(double period) : ftid::test::FakeArm(period, startPose()) {}
  Status waitForState(std::chrono::nanoseconds timeout, ur::ArmState* out) noexcept override {
    if (std::this_thread::get_id() == main_) return ftid::test::FakeArm::waitForState(timeout, out);
    if (!counter_) counter_.emplace();
    loop_allocations_ = counter_->count();
    ++loop_calls_;
    if (++calls_ % 500 == 0) return Status::kTimeout;
    const Status s = ftid::test::FakeArm::waitForState(timeout, out);
    if (s == Status::kFault) counter_.reset();  // end of the drain: release the counter here
    return s;
  }
  std::size_t loop_allocations_ = 0;
  std::size_t loop_calls_ = 0;

 private:
  static JointVector startPose() {
    JointVector q;
    q << 0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0;
    return q;
  }
  std::thread::id main_ = std::this_thread::get_id();
  std::optional<ftid::test::ScopedAllocationCounter> counter_;
  std::size_t calls_ = 0;
};

ftid::trajectory::FourierTrajectory makeTrajectory() {
  std::array<std::array<double, 16>, 6> a{}, b{};
  for (int j = 0; j < 6; ++j) {
    a[j][0] = 0.2;
    a[j][1] = -0.2;
    b[j][0] = -0.1;
    b[j][1] = 0.05;
  }
  JointVector q0;
  q0 << 0.05, -1.55, 1.55, -1.55, -1.55, 0.05;
  return ftid::trajectory::FourierTrajectory(q0, 0.5, 2, 8.0, a, b);
}

struct Sink {
  ftid::rt::SpscQueue<double, 1024> queue;
  ftid::rt::Mailbox<ur::ArmState> latest;
  static void hook(void* ctx, const ftid::motion::RecordedTick& t) noexcept {
    auto* self = static_cast<Sink*>(ctx);
    self->queue.tryPush(t.state.timestamp);
    self->latest.tryPush(t.state);
  }
};

}  // namespace

TEST(RtRobotLoop, MotionRunnerCycleDoesNotAllocate) {
  FakeArm arm(0.002);
  ftid::motion::MotionConfig cfg;
  cfg.realtime.enable = false;  // the counting does not depend on the scheduling class
  const auto traj = makeTrajectory();
  ftid::motion::EvaluatedTrajectory<ftid::trajectory::FourierTrajectory> src(traj);
  ftid::motion::MotionRunner runner(arm, cfg, ftid::motion::MotionRunner::capacityFor(8.0, 0.002));
  Sink sink;
  const auto r = runner.run(src, nullptr, &Sink::hook, &sink);
  ASSERT_EQ(r.status, ftid::motion::RunStatus::kCompleted) << r.message;
  EXPECT_GT(arm.loop_calls_, 4000u);  // 8 s at 500 Hz plus approach/settle
  EXPECT_GT(r.stats.missed, 5u);      // the missed-cycle path ran too
  EXPECT_GT(arm.targets, 4000u);
  // The loop armed the program's watchdog itself (its first cycles are counted too).
  EXPECT_EQ(arm.program.watchdog_requests, 1);
  EXPECT_EQ(arm.targets_before_watchdog, 0u);
  EXPECT_EQ(arm.loop_allocations_, 0u);
}

TEST(RtRobotLoop, RtdeStreamingCallsDoNotAllocate) {
  ftid::simrobot::SimRobotConfig sc;
  sc.model = ftid::simrobot::RobotModel::kUR10e;
  sc.rtde_port = sc.dashboard_port = sc.script_port = 0;
  ftid::simrobot::SimRobot sim(sc);
  sim.start();
  ur::RtdeArmConfig ac;
  ac.rtde_port = sim.rtdePort();
  ac.script_port = sim.scriptPort();
  ur::RtdeArm arm(ac);
  arm.connect();
  arm.uploadProgram();
  ur::ArmState st;
  ASSERT_EQ(arm.waitForState(100ms, &st), Status::kOk);
  arm.resetServoReference(st.q, st.qd);
  JointVector q = st.q;
  std::size_t ok = 0;
  ftid::test::ScopedAllocationCounter counter;
  for (int k = 0; k < 1000; ++k) {
    if (arm.waitForState(10ms, &st) != Status::kOk) continue;
    q[5] += 1e-4;
    if (arm.sendServoTarget(q) == Status::kOk) ++ok;
  }
  const std::size_t allocations = counter.count();
  EXPECT_GT(ok, 900u);
  EXPECT_EQ(allocations, 0u);
}

// Positive controls: in this binary the counter sees a deliberate allocation of every kind.
FTID_ALLOCATION_COUNTER_CONTROLS();
