#include "ftid/drivers/ur/rtde_arm.hpp"

#include <cmath>
#include <string>

#include "ftid/common/error.hpp"

namespace ftid::drivers::ur {

namespace {
JointVector toJoint(const Joint6& a) noexcept {
  JointVector v;
  for (int i = 0; i < 6; ++i) v[i] = a[static_cast<std::size_t>(i)];
  return v;
}
}  // namespace

RtdeArm::RtdeArm(RtdeArmConfig config) : config_(std::move(config)), safety_(config_.limits) {
  if (config_.register_offset != 0 && config_.register_offset != 24) {
    throw ConfigError("robot.register_offset must be 0 or 24 (got " + std::to_string(config_.register_offset) + ")");
  }
  if (!(config_.watchdog_min_hz >= 1.0 && config_.watchdog_min_hz <= 1000.0)) {
    throw ConfigError("robot watchdog_min_hz must be in [1, 1000] Hz (got " + std::to_string(config_.watchdog_min_hz) +
                      ")");
  }
}

RtdeArm::~RtdeArm() { disconnect(); }

void RtdeArm::connect() {
  client_.connect(config_.host, config_.rtde_port, config_.connect_timeout);
  if (!client_.negotiateProtocolVersion(rtde::kProtocolVersion2)) {
    throw DriverError("RTDE " + config_.host + ":" + std::to_string(config_.rtde_port) +
                      ": controller refused protocol version 2");
  }
  version_ = client_.controllerVersion();
  period_ = version_.major >= 5 ? 0.002 : 0.008;
  client_.setupOutputs(1.0 / period_, RtdeClient::defaultOutputNames(config_.register_offset));
  const int o = config_.register_offset;
  std::vector<std::string> servo_names = {"input_int_register_" + std::to_string(o)};
  for (int k = 0; k <= 10; ++k) servo_names.push_back("input_double_register_" + std::to_string(o + k));
  servo_pkg_ = InputPackage(client_.setupInputs(servo_names));
  command_pkg_ = InputPackage(client_.setupInputs(
      {"input_int_register_" + std::to_string(o), "input_double_register_" + std::to_string(o)}));
  servo_pkg_.setInt32(0, kCmdServoJ);
  servo_pkg_.setDouble(9, period_);
  servo_pkg_.setDouble(10, config_.lookahead_time);
  servo_pkg_.setDouble(11, config_.gain);
  client_.start();
  last_timestamp_ = -1.0;
}

void RtdeArm::disconnect() noexcept { client_.disconnect(); }

Status RtdeArm::waitForState(std::chrono::nanoseconds timeout, ArmState* out) noexcept {
  const Status s = client_.tryReceiveState(timeout, &raw_);
  if (s != Status::kOk) {
    if (s == Status::kFault) faults_.raise(kFaultRobotTimeout);
    return s;
  }
  out->timestamp = raw_.timestamp;
  out->q = toJoint(raw_.actual_q);
  out->qd = toJoint(raw_.actual_qd);
  out->target_q = toJoint(raw_.target_q);
  out->target_qd = toJoint(raw_.target_qd);
  out->target_qdd = toJoint(raw_.target_qdd);
  for (int i = 0; i < 6; ++i) out->tcp_pose[i] = raw_.actual_TCP_pose[static_cast<std::size_t>(i)];
  out->robot_mode = raw_.robot_mode;
  out->safety_mode = raw_.safety_mode;
  out->runtime_state = raw_.runtime_state;
  out->robot_status_bits = raw_.robot_status_bits;
  out->safety_status_bits = raw_.safety_status_bits;
  out->script_state = raw_.output_int_register[static_cast<std::size_t>(config_.register_offset)];
  out->speed_scaling = raw_.speed_scaling;
  out->host_receive_ns = raw_.host_receive_ns;
  std::uint32_t lost = raw_.packages_skipped;
  if (last_timestamp_ >= 0.0) {
    const double steps = std::round((raw_.timestamp - last_timestamp_) / period_);
    if (steps > 1.0 && steps < 1e6) lost = static_cast<std::uint32_t>(steps) - 1;
  }
  last_timestamp_ = raw_.timestamp;
  out->packages_skipped = lost;
  return Status::kOk;
}

void RtdeArm::resetServoReference(const JointVector& q, const JointVector& qd) noexcept {
  safety_.reset(q, qd);
  accepted_timestamp_ = last_timestamp_;
  for (int i = 0; i < 6; ++i) servo_pkg_.setDouble(static_cast<std::size_t>(1 + i), q[i]);
}

Status RtdeArm::sendServoTarget(const JointVector& q) noexcept {
  // The step must be reachable in the robot time since the previous accepted target: after lost
  // packages the controller held the old target for the missed ticks.
  double dt = period_;
  if (accepted_timestamp_ >= 0.0 && last_timestamp_ - accepted_timestamp_ > period_) {
    dt = last_timestamp_ - accepted_timestamp_;
  }
  last_reject_ = safety_.check(q, dt);
  if (last_reject_ != ServoReject::kNone) {
    faults_.raise(kFaultTargetRejected);
    sendHold();
    return Status::kRejected;
  }
  accepted_timestamp_ = last_timestamp_;
  for (int i = 0; i < 6; ++i) servo_pkg_.setDouble(static_cast<std::size_t>(1 + i), q[i]);
  return client_.trySendInputs(servo_pkg_);
}

Status RtdeArm::sendHold() noexcept {
  if (!safety_.initialised()) return sendCommand(kCmdNone);
  return client_.trySendInputs(servo_pkg_);  // still holds the last accepted target
}

Status RtdeArm::sendServoStop() noexcept { return sendCommand(kCmdServoStop, config_.servo_stop_deceleration); }

Status RtdeArm::sendArmWatchdog() noexcept { return sendCommand(kCmdSetWatchdog, config_.watchdog_min_hz); }

Status RtdeArm::sendClearCommand() noexcept { return sendCommand(kCmdNone); }

Status RtdeArm::sendCommand(std::int32_t command, double arg0) noexcept {
  command_pkg_.setInt32(0, command);
  command_pkg_.setDouble(1, arg0);
  return client_.trySendInputs(command_pkg_);
}

void RtdeArm::uploadProgram() {
  sendCommand(kCmdNone);  // a stale command left in the register must not run in the new program
  ServoProgramConfig pc;
  pc.register_offset = config_.register_offset;
  pc.step_time = period_;
  pc.lookahead_time = config_.lookahead_time;
  pc.gain = config_.gain;
  uploadScript(config_.host, config_.script_port, buildServoProgram(pc), config_.connect_timeout);
  ArmState st;
  const bool ok = waitUntil(
      [](const ArmState& s) { return s.runtime_state == rtde::kRuntimePlaying && s.script_state == kScriptReady; },
      config_.program_start_timeout, &st);
  if (!ok) {
    throw DriverError("the servo program did not start within " +
                      std::to_string(config_.program_start_timeout.count()) + " ms (runtime_state " +
                      rtde::runtimeStateName(st.runtime_state) + ", robot_mode " + rtde::robotModeName(st.robot_mode) +
                      ", safety_mode " + rtde::safetyModeName(st.safety_mode) + ", script register " +
                      std::to_string(st.script_state) + ")");
  }
}

void RtdeArm::armWatchdog() {
  ArmState st;
  auto send_and_wait = [&](std::int32_t cmd, double arg, std::int32_t want) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(2000);
    sendCommand(cmd, arg);
    while (std::chrono::steady_clock::now() < deadline) {
      const Status s = waitForState(std::chrono::milliseconds(100), &st);
      if (s == Status::kFault) break;
      if (s == Status::kOk && st.script_state == want) return true;
      if (s == Status::kOk && st.runtime_state != rtde::kRuntimePlaying) break;
      sendCommand(cmd, arg);  // keeps the (maybe already armed) watchdog fed
    }
    return false;
  };
  if (!send_and_wait(kCmdSetWatchdog, config_.watchdog_min_hz, kScriptDone) ||
      !send_and_wait(kCmdNone, 0.0, kScriptReady)) {
    throw DriverError(std::string("arming the RTDE watchdog failed (runtime_state ") +
                      rtde::runtimeStateName(st.runtime_state) + ", script register " +
                      std::to_string(st.script_state) + ")");
  }
}

void RtdeArm::stopProgram() noexcept {
  if (!client_.isConnected()) return;
  ArmState st;
  // A non-real-time command (e.g. servoStop) leaves the program "executing" until cleared with 0.
  auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(500);
  sendCommand(kCmdNone);
  while (std::chrono::steady_clock::now() < deadline) {
    const Status s = waitForState(std::chrono::milliseconds(100), &st);
    if (s == Status::kFault) return;
    if (s == Status::kOk && (st.script_state == kScriptReady || st.runtime_state != rtde::kRuntimePlaying)) break;
    sendCommand(kCmdNone);
  }
  deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(1000);
  sendCommand(kCmdStopScript);
  while (std::chrono::steady_clock::now() < deadline) {
    const Status s = waitForState(std::chrono::milliseconds(100), &st);
    if (s == Status::kFault) return;
    if (s == Status::kOk && st.runtime_state != rtde::kRuntimePlaying) break;
    sendCommand(kCmdStopScript);
  }
  sendCommand(kCmdNone);
}

}  // namespace ftid::drivers::ur
