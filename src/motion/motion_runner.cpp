#include "ftid/motion/motion_runner.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

#include "ftid/common/error.hpp"
#include "ftid/drivers/ur/rtde_protocol.hpp"
#include "ftid/drivers/ur/servo_program.hpp"
#include "ftid/rt/cyclic_executor.hpp"
#include "ftid/rt/rt_thread.hpp"

namespace ftid::motion {

namespace rtde = drivers::ur::rtde;
using drivers::ur::ArmState;

const char* runStatusName(RunStatus s) noexcept {
  switch (s) {
    case RunStatus::kCompleted: return "completed";
    case RunStatus::kAborted: return "aborted";
    case RunStatus::kNotReady: return "robot not ready";
    case RunStatus::kProtectiveStop: return "protective stop";
    case RunStatus::kEmergencyStop: return "emergency stop";
    case RunStatus::kSafetyFault: return "safety fault";
    case RunStatus::kModeChanged: return "robot mode changed";
    case RunStatus::kProgramStopped: return "robot program stopped";
    case RunStatus::kLostPackets: return "lost state packages";
    case RunStatus::kConnectionLost: return "connection lost";
    case RunStatus::kTrackingError: return "tracking error";
    case RunStatus::kTargetRejected: return "servo target rejected";
    case RunStatus::kSpeedScaled: return "speed scaling active";
    case RunStatus::kRefused: return "motion refused by the pre-motion check";
    case RunStatus::kWatchdogNotArmed: return "robot program watchdog not armed";
  }
  return "unknown";
}

// ------------------------------------------------------------------------------------------------
SampledTrajectory::SampledTrajectory(std::vector<double> t, std::vector<JointVector> q)
    : t_(std::move(t)), q_(std::move(q)) {
  if (t_.size() < 2 || t_.size() != q_.size()) {
    throw DataError("sampled trajectory: need at least two samples with one pose each");
  }
  if (std::abs(t_.front()) > 1e-9) {
    throw DataError("sampled trajectory: first sample must be at t = 0 (got " + std::to_string(t_.front()) + ")");
  }
  for (std::size_t i = 0; i < t_.size(); ++i) {
    if (!std::isfinite(t_[i]) || !q_[i].allFinite()) {
      throw DataError("sampled trajectory: non-finite value in sample " + std::to_string(i + 1));
    }
    if (i > 0 && !(t_[i] > t_[i - 1])) {
      throw DataError("sampled trajectory: time not strictly increasing at sample " + std::to_string(i + 1));
    }
  }
}

bool SampledTrajectory::sample(double t, JointVector* q) const noexcept {
  if (t <= t_.front()) {
    *q = q_.front();
    return true;
  }
  if (t >= t_.back()) {
    *q = q_.back();
    return true;
  }
  if (cursor_ >= t_.size() - 1 || t_[cursor_] > t) cursor_ = 0;
  if (t - t_[cursor_] > 1.0) {  // far jump: binary search
    cursor_ = static_cast<std::size_t>(std::upper_bound(t_.begin(), t_.end(), t) - t_.begin()) - 1;
  }
  while (cursor_ + 1 < t_.size() && t_[cursor_ + 1] <= t) ++cursor_;
  const std::size_t i = cursor_;
  const double w = (t - t_[i]) / (t_[i + 1] - t_[i]);
  *q = (1.0 - w) * q_[i] + w * q_[i + 1];
  return true;
}

// ------------------------------------------------------------------------------------------------
namespace {

struct Failure {
  RunStatus status = RunStatus::kCompleted;
  double timestamp = 0.0;
  int joint = -1;
  double value = 0.0;
  double limit = 0.0;
  std::int64_t code = 0;
};

double quintic(double s) noexcept {
  s = s < 0 ? 0 : (s > 1 ? 1 : s);
  return s * s * s * (10.0 - 15.0 * s + 6.0 * s * s);
}

struct RunCycle {
  drivers::ur::Arm& arm;
  const JointTrajectorySource& traj;
  const MotionConfig& cfg;
  std::vector<RecordedTick>& rec;
  std::size_t capacity;
  CycleHook hook;
  void* hook_context;
  const std::atomic<bool>* abort;
  RunProgress& progress;
  double period;
  std::uint32_t max_missed = 3;  // lost_time_limit in ticks
  std::uint32_t max_missed_startup = 3;  // startup_lost_time_limit in ticks
  std::uint32_t startup_ticks = 0;       // startup_grace in ticks
  std::uint32_t ticks_seen = 0;          // states and misses since the loop started
  std::uint32_t arm_timeout_ticks = 0;   // watchdog_arm_timeout in ticks

  /// Arming the servo program's RTDE watchdog in the loop's first cycles (before any servo target):
  /// request (command 35) until the program reports done (2), then clear (0) until ready (1).
  enum class Arming : std::uint8_t { kRequest, kClear, kArmed };
  Arming arming = Arming::kRequest;

  /// Keeps the command register written while arming (a lost tick repeats the current step).
  Status sendArmingStep() noexcept {
    return arming == Arming::kRequest ? arm.sendArmWatchdog() : arm.sendClearCommand();
  }

  /// Lost ticks tolerated now: more during the loop's first startup_ticks (a start-up burst on a
  /// loaded host), never more than the program's own watchdog allows.
  std::uint32_t lostLimit() const noexcept { return ticks_seen < startup_ticks ? max_missed_startup : max_missed; }

  std::size_t n = 0;
  std::size_t not_recorded = 0;
  ArmState state{};
  Phase phase = Phase::kApproach;
  JointVector q_a0 = JointVector::Zero(), q_a1 = JointVector::Zero(), q_end = JointVector::Zero();
  double approach_T = 0.0;
  double approach_t0 = -1.0;
  double settle_start = -1.0;
  double excite_t0 = -1.0;
  double sent_tn = -1.0;  ///< trajectory time of the last excitation target sent (-1: none yet)
  double finish_start = -1.0;
  double max_tracking = 0.0;
  Failure failure{};

  Status waitForTick(std::chrono::nanoseconds timeout) noexcept { return arm.waitForState(timeout, &state); }

  rt::CycleAction fail(RunStatus status, int joint = -1, double value = 0.0, double limit = 0.0,
                       std::int64_t code = 0) noexcept {
    if (failure.status == RunStatus::kCompleted) {
      failure = {status, state.timestamp, joint, value, limit, code};
    }
    phase = Phase::kStopping;
    arm.sendServoStop();
    return rt::CycleAction::kStop;
  }

  rt::CycleAction onMissed(std::uint32_t consecutive) noexcept {
    ++ticks_seen;
    const std::uint32_t limit = lostLimit();
    if (consecutive >= limit) {
      return fail(RunStatus::kLostPackets, -1, static_cast<double>(consecutive), static_cast<double>(limit));
    }
    if (arming != Arming::kArmed) {
      sendArmingStep();
    } else {
      arm.sendHold();
    }
    return rt::CycleAction::kContinue;
  }

  void record(const RecordedTick& t) noexcept {
    if (n < capacity) {
      rec[n++] = t;
    } else {
      ++not_recorded;
    }
  }

  rt::CycleAction onTick() noexcept {
    RecordedTick tick = beginTick();
    const ArmState& s = state;
    rt::CycleAction action = checkArmState(s);
    if (action == rt::CycleAction::kStop) return finishTick(tick, action);
    if (!advanceArming(s, &action)) return finishTick(tick, action);
    JointVector target = q_a1;
    action = stepPhase(s, &target);
    progress.phase.store(static_cast<int>(phase), std::memory_order_relaxed);
    if (phase != Phase::kStopping) action = sendTarget(target, action, &tick);
    return finishTick(tick, action);
  }

  /// Counts the tick (with the packages the controller skipped) and starts its record: the state,
  /// the phase, no command yet, and the trajectory time once the excitation has started.
  RecordedTick beginTick() noexcept {
    // The gap between the last state read before the loop (readiness) and the loop's first state
    // is set-up time on the calling thread, not a loss: nothing is streamed and the arm rests.
    if (ticks_seen == 0) state.packages_skipped = 0;
    const ArmState& s = state;
    ticks_seen += 1 + s.packages_skipped;
    RecordedTick tick;
    tick.state = s;
    tick.phase = phase;
    tick.q_command.setConstant(std::numeric_limits<double>::quiet_NaN());
    if (phase == Phase::kExcite || phase == Phase::kFinish) tick.t_traj = s.timestamp - excite_t0;
    return tick;
  }

  /// Records the tick, hands it to the hook and returns the cycle's action.
  rt::CycleAction finishTick(const RecordedTick& tick, rt::CycleAction action) noexcept {
    record(tick);
    if (hook) hook(hook_context, tick);
    return action;
  }

  /// Stops (fail) on an operator abort, a safety stop, a robot mode or program change, too many
  /// lost packages or (if configured) speed scaling; else kContinue.
  rt::CycleAction checkArmState(const ArmState& s) noexcept {
    rt::CycleAction action = rt::CycleAction::kContinue;
    if (abort && abort->load(std::memory_order_relaxed)) {
      action = fail(RunStatus::kAborted);
    } else if (s.safety_mode != rtde::kSafetyModeNormal && s.safety_mode != rtde::kSafetyModeReduced) {
      const RunStatus st = s.safety_mode == rtde::kSafetyModeProtectiveStop ? RunStatus::kProtectiveStop
                           : (s.safety_mode == rtde::kSafetyModeRobotEmergencyStop ||
                              s.safety_mode == rtde::kSafetyModeSystemEmergencyStop)
                               ? RunStatus::kEmergencyStop
                               : RunStatus::kSafetyFault;
      action = fail(st, -1, 0.0, 0.0, s.safety_mode);
    } else if (s.robot_mode != rtde::kRobotModeRunning) {
      action = fail(RunStatus::kModeChanged, -1, 0.0, 0.0, s.robot_mode);
    } else if (s.runtime_state != rtde::kRuntimePlaying) {
      action = fail(RunStatus::kProgramStopped, -1, 0.0, 0.0, s.runtime_state);
    } else if (s.packages_skipped >= lostLimit()) {
      action = fail(RunStatus::kLostPackets, -1, s.packages_skipped, lostLimit());
    } else if (cfg.abort_on_speed_scaling && s.speed_scaling < 0.99) {
      action = fail(RunStatus::kSpeedScaled, -1, s.speed_scaling, 1.0);
    }
    return action;
  }

  /// Advances the watchdog arming by the program's script register. Returns true once armed;
  /// until then no servo target is sent (the arm rests): the current arming step is, or *action
  /// fails after arm_timeout_ticks or on a lost connection.
  bool advanceArming(const ArmState& s, rt::CycleAction* action) noexcept {
    if (arming == Arming::kArmed) return true;
    if (arming == Arming::kRequest && s.script_state == drivers::ur::kScriptDone) arming = Arming::kClear;
    if (arming == Arming::kClear && s.script_state == drivers::ur::kScriptReady) arming = Arming::kArmed;
    if (arming == Arming::kArmed) return true;
    if (ticks_seen > arm_timeout_ticks) {
      *action = fail(RunStatus::kWatchdogNotArmed, -1, 0.0, 0.0, s.script_state);
    } else if (sendArmingStep() != Status::kOk) {
      *action = fail(RunStatus::kConnectionLost);
    }
    return false;
  }

  /// The target of the current phase for the next tick (*target, q_a1 unless the phase sets it),
  /// moving on to the next phase when this one is done. Returns kStop when the run ends.
  rt::CycleAction stepPhase(const ArmState& s, JointVector* target) noexcept {
    switch (phase) {
      case Phase::kApproach:
        approachTarget(s, target);
        return rt::CycleAction::kContinue;
      case Phase::kSettle:
        return settleTarget(s, target);
      case Phase::kExcite:
        return exciteTarget(s, target);
      case Phase::kFinish:
        *target = q_end;
        return s.timestamp - finish_start >= cfg.settle_time ? rt::CycleAction::kStop
                                                              : rt::CycleAction::kContinue;
      case Phase::kStopping:
        return rt::CycleAction::kStop;
    }
    return rt::CycleAction::kContinue;
  }

  /// Approach: q_a0 + (q_a1 - q_a0) * quintic(tau / approach_T) at tau = t + period since the
  /// first tick; at tau >= approach_T the target is q_a1 and the arm settles.
  void approachTarget(const ArmState& s, JointVector* target) noexcept {
    if (approach_t0 < 0) approach_t0 = s.timestamp;
    const double tau = s.timestamp + period - approach_t0;
    if (tau >= approach_T) {
      *target = q_a1;
      phase = Phase::kSettle;
      settle_start = s.timestamp;
    } else {
      *target = q_a0 + (q_a1 - q_a0) * quintic(tau / approach_T);
    }
  }

  /// Settle: holds q_a1 until every joint is within start_tolerance, then sends the trajectory's
  /// t = 0 (the excitation starts); fails after settle_timeout.
  rt::CycleAction settleTarget(const ArmState& s, JointVector* target) noexcept {
    *target = q_a1;
    const double err = (s.q - q_a1).cwiseAbs().maxCoeff();
    if (err < cfg.start_tolerance) {
      phase = Phase::kExcite;
      excite_t0 = s.timestamp + period;  // the target sent now is applied at the next tick
      traj.sample(0.0, target);
      sent_tn = 0.0;
    } else if (s.timestamp - settle_start > cfg.settle_timeout) {
      int j = 0;
      (s.q - q_a1).cwiseAbs().maxCoeff(&j);
      return fail(RunStatus::kTrackingError, j, err, cfg.start_tolerance, 1);
    }
    return rt::CycleAction::kContinue;
  }

  /// The tracking error max_j |q_j - q_ref_j| at trajectory time tt (kept in max_tracking); fails
  /// (kStop) beyond tracking_error_limit.
  rt::CycleAction checkTracking(const ArmState& s, double tt) noexcept {
    // The tracking error is measured against what the arm was commanded: the trajectory at
    // the time of the last target sent, not beyond it. After a host stall (no target for a
    // few ticks, the controller holding the last one) the trajectory's time ran on while
    // the arm rightly stayed at the last target; that lag, |qd| x stall, is the host's and
    // aborted the demo's identification on a loaded machine (issue 26). An arm that does
    // not follow its commands (blocked, collided, too slow) deviates from them and still
    // aborts at once, on the first tick beyond the limit.
    JointVector q_ref;
    traj.sample(sent_tn >= 0.0 ? std::min(tt, sent_tn) : tt, &q_ref);
    int j = 0;
    const double err = (s.q - q_ref).cwiseAbs().maxCoeff(&j);
    if (err > max_tracking) max_tracking = err;
    if (err > cfg.tracking_error_limit) {
      return fail(RunStatus::kTrackingError, j, err, cfg.tracking_error_limit, 0);
    }
    return rt::CycleAction::kContinue;
  }

  /// Sends the target; a rejected one (the joint of a non-finite value, if any) or a lost
  /// connection fails the run, else the tick records it as its command. Returns the action.
  rt::CycleAction sendTarget(const JointVector& target, rt::CycleAction action, RecordedTick* tick) noexcept {
    const Status st = arm.sendServoTarget(target);
    if (st == Status::kRejected) {
      int j = -1;
      for (int i = 0; i < kNumJoints; ++i) {
        if (!std::isfinite(target[i])) j = i;
      }
      action = fail(RunStatus::kTargetRejected, j, 0.0, 0.0, 0);
    } else if (st != Status::kOk) {
      action = fail(RunStatus::kConnectionLost);
    } else {
      tick->q_command = target;
    }
    return action;
  }

  /// Excitation: checks the tracking, then targets the trajectory at tn = t + period - excite_t0
  /// (its end pose, and the finish, at tn >= duration); publishes the elapsed trajectory time.
  rt::CycleAction exciteTarget(const ArmState& s, JointVector* target) noexcept {
    const double tt = s.timestamp - excite_t0;
    if (tt >= 0.0 && checkTracking(s, tt) == rt::CycleAction::kStop) return rt::CycleAction::kStop;
    const double tn = s.timestamp + period - excite_t0;
    if (tn >= traj.duration()) {
      traj.sample(traj.duration(), target);
      q_end = *target;
      phase = Phase::kFinish;
      finish_start = s.timestamp;
    } else {
      traj.sample(tn, target);
      sent_tn = tn;
    }
    progress.elapsed.store(tn < traj.duration() ? tn : traj.duration(), std::memory_order_relaxed);
    return rt::CycleAction::kContinue;
  }
  /// After the loop: keep reading until the arm rests (bounded), recording the stop.
  void drainStop() noexcept {
    const std::int64_t deadline = rt::monotonicNs() + static_cast<std::int64_t>(cfg.stop_timeout * 1e9);
    const auto timeout = std::chrono::nanoseconds(static_cast<std::int64_t>(period * cfg.timeout_periods * 1e9));
    int at_rest = 0;
    while (rt::monotonicNs() < deadline) {
      const Status st = arm.waitForState(timeout, &state);
      if (st == Status::kFault) return;
      if (st != Status::kOk) {
        arm.sendServoStop();
        continue;
      }
      RecordedTick tick;
      tick.state = state;
      tick.phase = Phase::kStopping;
      tick.q_command.setConstant(std::numeric_limits<double>::quiet_NaN());
      record(tick);
      if (hook) hook(hook_context, tick);
      arm.sendServoStop();
      at_rest = state.qd.cwiseAbs().maxCoeff() < 1e-3 ? at_rest + 1 : 0;
      if (at_rest >= 3) return;
    }
  }
};

/// Duration of the quintic approach move (peak speed and acceleration within the configured ones).
double approachDuration(const JointVector& from, const JointVector& to, double period, const MotionConfig& cfg) {
  double T = 2.0 * period;
  for (int i = 0; i < kNumJoints; ++i) {
    const double d = std::abs(to[i] - from[i]);
    T = std::max({T, 1.875 * d / cfg.approach_velocity, std::sqrt(5.7735 * d / cfg.approach_acceleration)});
  }
  return T;
}

std::string describe(const Failure& f, const MotionConfig& cfg, double t0) {
  char buf[512];
  const double t_rel = t0 >= 0 ? f.timestamp - t0 : 0.0;
  switch (f.status) {
    case RunStatus::kAborted:
      std::snprintf(buf, sizeof buf, "aborted by the operator at robot time %.3f s; the arm was stopped", f.timestamp);
      break;
    case RunStatus::kProtectiveStop:
    case RunStatus::kEmergencyStop:
    case RunStatus::kSafetyFault:
      std::snprintf(buf, sizeof buf, "robot entered safety mode %s at robot time %.3f s (trajectory t = %.3f s)",
                    rtde::safetyModeName(static_cast<std::int32_t>(f.code)), f.timestamp, t_rel);
      break;
    case RunStatus::kModeChanged:
      std::snprintf(buf, sizeof buf, "robot mode changed to %s at robot time %.3f s",
                    rtde::robotModeName(static_cast<std::int32_t>(f.code)), f.timestamp);
      break;
    case RunStatus::kProgramStopped:
      std::snprintf(buf, sizeof buf,
                    "the robot program stopped (runtime_state %s) at robot time %.3f s (watchdog, stop button or "
                    "controller)",
                    rtde::runtimeStateName(static_cast<std::uint32_t>(f.code)), f.timestamp);
      break;
    case RunStatus::kLostPackets:
      std::snprintf(buf, sizeof buf,
                    "lost %.0f state packages in a row (limit %.0f) near robot time %.3f s (late host, "
                    "network or controller)",
                    f.value, f.limit, f.timestamp);
      break;
    case RunStatus::kConnectionLost:
      std::snprintf(buf, sizeof buf, "connection to the controller lost near robot time %.3f s", f.timestamp);
      break;
    case RunStatus::kTrackingError:
      if (f.code == 1) {
        std::snprintf(buf, sizeof buf,
                      "start pose not reached within %.1f s: joint %d is %.4f rad away (tolerance %.4f rad)",
                      cfg.settle_timeout, f.joint + 1, f.value, f.limit);
      } else {
        std::snprintf(buf, sizeof buf,
                      "tracking error %.4f rad on joint %d exceeds %.4f rad at trajectory t = %.3f s", f.value,
                      f.joint + 1, f.limit, t_rel);
      }
      break;
    case RunStatus::kTargetRejected:
      std::snprintf(buf, sizeof buf,
                    "the last-hop safety check rejected a servo target at robot time %.3f s (non-finite, outside "
                    "the joint limits or beyond the velocity/acceleration limits); the arm was held and stopped",
                    f.timestamp);
      break;
    case RunStatus::kSpeedScaled:
      std::snprintf(buf, sizeof buf, "the controller scaled the speed to %.2f at robot time %.3f s", f.value,
                    f.timestamp);
      break;
    case RunStatus::kWatchdogNotArmed:
      std::snprintf(buf, sizeof buf,
                    "the robot program did not confirm arming its RTDE watchdog within %.2f s (script register "
                    "%lld at robot time %.3f s); nothing was moved",
                    cfg.watchdog_arm_timeout, static_cast<long long>(f.code), f.timestamp);
      break;
    default:
      std::snprintf(buf, sizeof buf, "%s", runStatusName(f.status));
  }
  return buf;
}

}  // namespace

// ------------------------------------------------------------------------------------------------
MotionRunner::MotionRunner(drivers::ur::Arm& arm, MotionConfig config, std::size_t capacity)
    : arm_(arm), config_(std::move(config)), recording_(capacity), capacity_(capacity) {}

std::size_t MotionRunner::capacityFor(double duration, double period, double margin_s) {
  return static_cast<std::size_t>((duration + margin_s) / period) + 16;
}

PlannedMotion MotionRunner::plan(const JointTrajectorySource& trajectory, const JointVector& current,
                                 double period) const {
  // Mirrors RunCycle::onTick: approach target at tau = (k + 1) * period after the first tick,
  // then the excitation at tn = k * period (k = 0, 1, ...) and finally the end pose.
  PlannedMotion p;
  p.period = period;
  p.current = current;
  JointVector start = JointVector::Zero();
  trajectory.sample(0.0, &start);
  const double T = approachDuration(current, start, period, config_);
  for (long k = 1;; ++k) {
    const double tau = static_cast<double>(k) * period;
    if (tau >= T) {
      p.approach.push_back(start);
      break;
    }
    p.approach.push_back(current + (start - current) * quintic(tau / T));
  }
  const double d = trajectory.duration();
  for (long k = 0;; ++k) {
    const double tn = static_cast<double>(k) * period;
    JointVector q = JointVector::Zero();
    if (tn >= d) {
      trajectory.sample(d, &q);
      p.t_traj.push_back(d);
      p.q_traj.push_back(q);
      break;
    }
    trajectory.sample(tn, &q);
    p.t_traj.push_back(tn);
    p.q_traj.push_back(q);
  }
  return p;
}

std::string MotionRunner::readinessProblem(const ArmState& s) {
  if (s.robot_mode != rtde::kRobotModeRunning) {
    return std::string("robot_mode is ") + rtde::robotModeName(s.robot_mode) +
           " (power on and release the brakes first)";
  }
  if (s.safety_mode != rtde::kSafetyModeNormal) {
    return std::string("safety_mode is ") + rtde::safetyModeName(s.safety_mode) +
           " (clear the stop on the pendant or with 'unlock protective stop')";
  }
  if (s.runtime_state != rtde::kRuntimePlaying) {
    return std::string("the robot program is not running (runtime_state ") + rtde::runtimeStateName(s.runtime_state) +
           ")";
  }
  if (s.script_state != 1) {
    return "the servo program is not ready for commands (script register " + std::to_string(s.script_state) + ")";
  }
  if (!s.q.allFinite()) return "the robot reports non-finite joint angles";
  return {};
}

RunResult MotionRunner::run(const JointTrajectorySource& trajectory, const std::atomic<bool>* abort, CycleHook hook,
                            void* hook_context) {
  RunResult result;
  recording_.resize(capacity_);  // (re)allocated here, never in the loop
  const double period = arm_.period();
  progress_.duration.store(trajectory.duration());
  progress_.elapsed.store(0.0);
  progress_.phase.store(0);

  // Readiness from a fresh state (non-real-time, before the loop thread starts).
  ArmState first{};
  Status st = Status::kTimeout;
  for (int i = 0; i < 5 && st != Status::kOk; ++i) {
    st = arm_.waitForState(std::chrono::milliseconds(200), &first);
    if (st == Status::kFault) break;
    arm_.sendHold();  // keeps the program's RTDE watchdog fed
  }
  if (st != Status::kOk) {
    result.status = st == Status::kFault ? RunStatus::kConnectionLost : RunStatus::kLostPackets;
    result.message = "no state from the controller before the run";
    return result;
  }
  const std::string problem = readinessProblem(first);
  if (!problem.empty()) {
    result.status = RunStatus::kNotReady;
    result.message = problem;
    return result;
  }
  JointVector start;
  if (!trajectory.sample(0.0, &start) || !start.allFinite()) {
    result.status = RunStatus::kTargetRejected;
    result.message = "the trajectory has no finite start pose";
    return result;
  }

  if (config_.preflight) {
    const std::string refusal = config_.preflight(plan(trajectory, first.q, period));
    if (!refusal.empty()) {
      result.status = RunStatus::kRefused;
      result.message = refusal;
      return result;
    }
  }

  RunCycle cycle{arm_, trajectory, config_, recording_, capacity_, hook, hook_context, abort, progress_, period};
  cycle.q_a0 = first.q;
  cycle.q_a1 = start;
  cycle.approach_T = approachDuration(first.q, start, period, config_);
  cycle.max_missed = static_cast<std::uint32_t>(std::max(1.0, std::round(config_.lost_time_limit / period)));
  arm_.resetServoReference(first.q, first.qd);

  rt::ExecutorConfig ec;
  ec.period = std::chrono::nanoseconds(static_cast<std::int64_t>(std::llround(period * 1e9)));
  ec.timeout_periods = config_.timeout_periods;
  // Start-up burst: at most startup_lost_time_limit, and never beyond 80 % of the servo program's
  // own watchdog (1 / watchdog_min_hz; the program stops the arm itself after that).
  cycle.max_missed_startup = std::max(
      cycle.max_missed, static_cast<std::uint32_t>(std::floor(config_.startup_lost_time_limit / period + 1e-9)));
  cycle.startup_ticks = static_cast<std::uint32_t>(std::ceil(config_.startup_grace / period));
  cycle.arm_timeout_ticks = static_cast<std::uint32_t>(std::ceil(config_.watchdog_arm_timeout / period));
  ec.max_consecutive_missed = std::max(cycle.max_missed, cycle.max_missed_startup) + 1;  // the cycle decides first
  rt::LoopExit exit = rt::LoopExit::kCycleStopped;
  progress_.running.store(true);
  result.realtime = rt::runInRealtimeThread(config_.realtime, [&] {
    exit = rt::runDeviceClocked(cycle, ec, &result.stats, nullptr);
    if (exit == rt::LoopExit::kDeviceFault) {
      cycle.failure.status = RunStatus::kConnectionLost;
      cycle.failure.timestamp = cycle.state.timestamp;
    } else if (exit == rt::LoopExit::kTooManyMissed && cycle.failure.status == RunStatus::kCompleted) {
      cycle.fail(RunStatus::kLostPackets, -1, cycle.max_missed, cycle.max_missed);
    }
    if (exit != rt::LoopExit::kDeviceFault) {
      arm_.sendServoStop();
      cycle.drainStop();
    }
  });
  progress_.running.store(false);

  for (std::size_t i = 0; i < cycle.n; ++i) result.stats.recordLost(recording_[i].state.packages_skipped);
  result.ticks_recorded = cycle.n;
  result.excitation_start_timestamp = cycle.excite_t0;
  result.max_tracking_error = cycle.max_tracking;
  result.status = cycle.failure.status;
  if (result.status == RunStatus::kCompleted) {
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "trajectory of %.3f s streamed at %.0f Hz; %zu ticks recorded; max tracking error %.4f rad",
                  trajectory.duration(), 1.0 / period, cycle.n, cycle.max_tracking);
    result.message = buf;
  } else {
    result.message = describe(cycle.failure, config_, cycle.excite_t0);
    result.message += "; " + std::to_string(cycle.n) + " ticks recorded";
  }
  if (cycle.not_recorded > 0) {
    result.message += " (" + std::to_string(cycle.not_recorded) + " ticks not recorded: buffer full)";
  }
  recording_.resize(cycle.n);
  return result;
}

}  // namespace ftid::motion
