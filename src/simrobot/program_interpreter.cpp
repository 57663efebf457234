// The register protocol of the two programs the controller model recognises (docs/robot.md,
// "Programs"): ftid's `ftid_servo` (include/ftid/drivers/ur/servo_program.hpp, whose ServoCommand
// codes and script states are used here) and ur_rtde's `rtde_control` (the same layout for the
// servo subset, plus the ur_rtde codes below). One program step per controller tick, as the
// programs' main loops end with sync().
#include <algorithm>
#include <cmath>
#include <iterator>
#include <string>

#include "ftid/drivers/ur/servo_program.hpp"
#include "ftid/simrobot/controller.hpp"

namespace ftid::simrobot {

namespace rtde = ftid::drivers::ur::rtde;
namespace ur = ftid::drivers::ur;

namespace {

// ur_rtde's command codes that ftid's program does not have (ur_rtde's rtde.h; the notes' §3.4).
constexpr std::int32_t kUrRtdeGetStepTime = 26;  ///< the controller period into out_double_o
/// The rest of rtde_control.script's real-time set (forceMode 6, speedJ 9, speedL 10, servoL 24,
/// toolContact 25, joint history 27, joint torques 38, 58, 66..71): acknowledged, not modelled.
constexpr std::int32_t kUrRtdeOtherRealtimeCommands[] = {6, 9, 10, 24, 25, 27, 38, 58, 66, 67, 68, 69, 70, 71};

// The servoJ input registers relative to the offset o (servo_program.hpp's register layout).
constexpr int kRegQ = 0;          ///< input_double o+0..5: q [rad]
constexpr int kRegMoveV = 6;      ///< input_double o+6: moveJ speed [rad/s]
constexpr int kRegMoveA = 7;      ///< input_double o+7: moveJ acceleration [rad/s^2]
constexpr int kRegServoT = 8;     ///< input_double o+8: servoj t [s]
constexpr int kRegLookahead = 9;  ///< input_double o+9: lookahead [s]
constexpr int kRegGain = 10;      ///< input_double o+10: gain
constexpr int kRegArg = 0;        ///< input_double o+0: the argument of 16 and 35
constexpr int kRegHeartbeat = 1;  ///< output_int o+1: ftid_servo's servo set-point count

// URScript movej's defaults when the client leaves v / a at 0.
constexpr double kMoveJDefaultSpeed = 1.05;  // [rad/s]
constexpr double kMoveJDefaultAcc = 1.4;     // [rad/s^2]

}  // namespace

void Controller::programStep() {
  if (runtime_state_ != rtde::kRuntimePlaying || program_ == ProgramKind::kNone ||
      program_ == ProgramKind::kOther) {
    return;
  }
  const int o = offset_;
  const std::int32_t cmd = reg_.in_int[static_cast<std::size_t>(o)];
  auto& script_state = reg_.out_int[static_cast<std::size_t>(o)];
  if (cmd == ur::kCmdNone) {
    executing_ = false;
    script_state = ur::kScriptReady;
    return;
  }
  if (cmd == ur::kCmdServoJ) {
    servoCommand(o);
    return;
  }
  if (program_ == ProgramKind::kUrRtde &&
      std::find(std::begin(kUrRtdeOtherRealtimeCommands), std::end(kUrRtdeOtherRealtimeCommands), cmd) !=
          std::end(kUrRtdeOtherRealtimeCommands)) {
    script_state = ur::kScriptReady;  // accepted, not modelled
    return;
  }
  if (executing_) return;  // a non-real-time command runs once until the client clears it
  executing_ = true;
  if (nonRealtimeCommand(o, cmd)) script_state = ur::kScriptDone;
}

void Controller::servoCommand(int o) {
  const auto in = [&](int k) { return reg_.in_double[static_cast<std::size_t>(o + k)]; };
  JointVector target;
  for (int i = 0; i < 6; ++i) target[i] = in(kRegQ + i);
  if (!target.allFinite()) {
    protectiveStop("non-finite servoj target");
    return;
  }
  for (int i = 0; i < 6; ++i) {
    if (target[i] < config_.position_lower[i] || target[i] > config_.position_upper[i]) {
      protectiveStop("servoj target outside joint limits (joint " + std::to_string(i + 1) + ")");
      return;
    }
  }
  const bool was_active = motion_.servoActive();
  const JointVector prev_target = was_active ? motion_.servoTarget() : motion_.q();
  motion_.setServoParameters(in(kRegServoT), in(kRegLookahead), in(kRegGain));
  if (config_.servo_step_protective_stop_factor > 0) {
    // A host that answers late (non-real-time scheduling) leaves the previous target in the
    // registers for a tick and then sends one covering two ticks: judge the step over the
    // time since the target last changed (at most 3 ticks, the runner's lost-package limit).
    const std::uint64_t held = was_active ? std::min<std::uint64_t>(ticks_ - servo_change_tick_, 3) : 1;
    const double t =
        std::max(motion_.servoStepTime(), static_cast<double>(std::max<std::uint64_t>(held, 1)) * dt_);
    for (int i = 0; i < 6; ++i) {
      const double speed = std::abs(target[i] - prev_target[i]) / t;
      if (speed > config_.velocity_limit[i] * config_.servo_step_protective_stop_factor) {
        protectiveStop("servoj step on joint " + std::to_string(i + 1) + " needs " + std::to_string(speed) +
                       " rad/s");
        return;
      }
    }
  }
  if (!was_active || target != motion_.servoTarget()) servo_change_tick_ = ticks_;
  motion_.servo(target);
  ++servo_commands_;
  reg_.out_int[static_cast<std::size_t>(o)] = ur::kScriptReady;
  if (program_ == ProgramKind::kFtid) {
    reg_.out_int[static_cast<std::size_t>(o + kRegHeartbeat)] =
        static_cast<std::int32_t>(servo_commands_ % 2000000000);
  }
}

// A non-real-time command, executed once. Returns true when it is done at once (the script
// state becomes "done"), false when it completes later (moveJ: at the end of the motion) or
// stopped the program.
bool Controller::nonRealtimeCommand(int o, std::int32_t cmd) {
  const auto in = [&](int k) { return reg_.in_double[static_cast<std::size_t>(o + k)]; };
  switch (cmd) {
    case ur::kCmdMoveJ: {  // q d0..5, v d6, a d7; "done" when the motion ends
      JointVector target;
      for (int i = 0; i < 6; ++i) target[i] = in(kRegQ + i);
      if (!target.allFinite()) {
        protectiveStop("non-finite movej target");
        return false;
      }
      motion_.moveJ(target, in(kRegMoveV) > 0 ? in(kRegMoveV) : kMoveJDefaultSpeed,
                    in(kRegMoveA) > 0 ? in(kRegMoveA) : kMoveJDefaultAcc);
      reg_.out_int[static_cast<std::size_t>(o)] = 0;  // busy
      return false;
    }
    case ur::kCmdServoStop:
      motion_.endServo();
      motion_.stop(in(kRegArg));
      return true;
    case kUrRtdeGetStepTime:
      reg_.out_double[static_cast<std::size_t>(o)] = dt_;
      return true;
    case ur::kCmdSetWatchdog:
      watchdog_armed_ = true;
      watchdog_fired_ = false;
      watchdog_register_ = o;
      watchdog_min_hz_ = in(kRegArg);
      int_write_tick_[static_cast<std::size_t>(o)] = ticks_;
      event("watchdog armed on input_int_register_" + std::to_string(o) + " at " +
            std::to_string(watchdog_min_hz_) + " Hz");
      return true;
    case ur::kCmdStopScript:
      reg_.out_int[static_cast<std::size_t>(o)] = ur::kScriptDone;
      stopProgram("stop command (" + std::to_string(ur::kCmdStopScript) + ") from the client");
      return false;
    default:
      return true;  // other non-real-time commands: answered "done"
  }
}

}  // namespace ftid::simrobot
