#pragma once
// The one fake of the arm seam (drivers::ur::Arm) for the motion loop's tests: a controller that
// never blocks, whose time advances one period per state and whose arm follows the servo target
// one tick late, running ftid's servo program (FakeServoProgram) one iteration per tick. Fault
// injection: a run of lost packages (timeouts), one read after unread packages (drain-to-latest).
// After sendServoStop() it answers five more states, then kFault (the link closes). Header-only,
// allocation-free; tests that need more (counting allocations on the loop thread) derive from it.
// The daemon's seam (daemon::ArmStateSource) has its own fakes in test/unit/daemon/fakes.hpp:
// docs/architecture.md, "Robot state types".
#include <chrono>
#include <cstddef>
#include <cstdint>

#include "fake_servo_program.hpp"
#include "ftid/drivers/ur/arm.hpp"
#include "ftid/drivers/ur/rtde_protocol.hpp"

namespace ftid::test {

class FakeArm : public drivers::ur::Arm {
 public:
  FakeArm(double period, const JointVector& q) : period_(period), q_(q), target_(q) {}

  Status waitForState(std::chrono::nanoseconds, drivers::ur::ArmState* out) noexcept override {
    if (stopping_ && ++stop_calls_ > 5) return Status::kFault;
    ++calls_;
    program.step();  // the program runs on whether or not its package reaches us
    if (calls_ >= timeout_from && calls_ < timeout_from + timeout_count) {
      ts_ += period_;  // the controller ran on; its package was lost
      return Status::kTimeout;
    }
    ts_ += period_;
    out->packages_skipped = 0;
    if (calls_ == gap_at_call) {  // the client did not read for gap_ticks: the newest package wins
      for (int k = 0; k < gap_ticks; ++k) program.step();
      ts_ += gap_ticks * period_;
      out->packages_skipped = static_cast<std::uint32_t>(gap_ticks);
    }
    out->timestamp = ts_;
    out->qd = (target_ - q_) / period_;
    q_ = target_;
    out->q = q_;
    out->target_q = q_;
    out->robot_mode = drivers::ur::rtde::kRobotModeRunning;
    out->safety_mode = drivers::ur::rtde::kSafetyModeNormal;
    out->runtime_state = drivers::ur::rtde::kRuntimePlaying;
    out->script_state = program.script;
    out->speed_scaling = 1.0;
    return Status::kOk;
  }
  Status sendServoTarget(const JointVector& q) noexcept override {
    target_ = q;
    program.command = 11;
    if (!program.watchdog_armed) ++targets_before_watchdog;
    ++targets;
    return Status::kOk;
  }
  Status sendHold() noexcept override {
    if (!reference_set) {  // like RtdeArm: no servo reference yet, so only clear the register
      program.command = 0;
      return Status::kOk;
    }
    program.command = 11;  // re-sends the servo package
    if (!program.watchdog_armed) ++targets_before_watchdog;
    return Status::kOk;
  }
  Status sendArmWatchdog() noexcept override {
    program.command = 35;
    return Status::kOk;
  }
  Status sendClearCommand() noexcept override {
    program.command = 0;
    return Status::kOk;
  }
  Status sendServoStop() noexcept override {
    program.command = 16;
    stopping_ = true;
    return Status::kOk;
  }
  void resetServoReference(const JointVector&, const JointVector&) noexcept override {
    reference_set = true;
  }
  double period() const noexcept override { return period_; }

  FakeServoProgram program;
  bool reference_set = false;
  std::size_t targets_before_watchdog = 0;  ///< servo targets or holds sent before command 35 ran
  std::size_t targets = 0;                  ///< servo targets sent
  int timeout_from = -1;  ///< waitForState call (1-based) from which timeout_count calls time out
  int timeout_count = 0;
  int gap_at_call = -1;  ///< waitForState call (1-based) that follows gap_ticks unread packages
  int gap_ticks = 0;

 private:
  double period_;
  double ts_ = 100.0;
  JointVector q_, target_;
  bool stopping_ = false;
  int stop_calls_ = 0;
  int calls_ = 0;
};

}  // namespace ftid::test
