// The controller model: modes, program control, watchdog, faults, the tick (controller.hpp).
// The register protocol of the programs is in program_interpreter.cpp, the joint motion in
// motion_model.cpp.
#include "ftid/simrobot/controller.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <sstream>

#include "ftid/common/error.hpp"
#include "ftid/drivers/ur/servo_program.hpp"

namespace ftid::simrobot {

namespace rtde = ftid::drivers::ur::rtde;
namespace ur = ftid::drivers::ur;

FaultKind parseFaultKind(const std::string& name) {
  static const std::map<std::string, FaultKind> m = {
      {"protective_stop", FaultKind::kProtectiveStop}, {"estop", FaultKind::kEmergencyStop},
      {"program_stop", FaultKind::kProgramStop},       {"drop", FaultKind::kDropPackets},
      {"late", FaultKind::kLatePackets},               {"disconnect", FaultKind::kDisconnect},
      {"stall", FaultKind::kStallTicks}};
  const auto it = m.find(name);
  if (it == m.end()) {
    throw ConfigError("unknown fault '" + name +
                      "' (expected protective_stop, estop, program_stop, drop, late, disconnect or stall)");
  }
  return it->second;
}

const char* faultKindName(FaultKind kind) noexcept {
  switch (kind) {
    case FaultKind::kProtectiveStop: return "protective_stop";
    case FaultKind::kEmergencyStop: return "estop";
    case FaultKind::kProgramStop: return "program_stop";
    case FaultKind::kDropPackets: return "drop";
    case FaultKind::kLatePackets: return "late";
    case FaultKind::kDisconnect: return "disconnect";
    case FaultKind::kStallTicks: return "stall";
  }
  return "unknown";
}

namespace {

double periodOf(RobotModel model) { return model == RobotModel::kUR10 ? 0.008 : 0.002; }

rtde::ControllerVersion versionOf(RobotModel model) {
  if (model == RobotModel::kUR10) return {3, 15, 8, 106339};
  return {5, 11, 1, 108318};
}

MotionLimits limitsOf(const SimRobotConfig& c) {
  MotionLimits l;
  l.omega_max_fraction = c.omega_max_fraction;
  l.velocity_limit = c.velocity_limit;
  l.acceleration_limit = c.acceleration_limit;
  l.stop_deceleration = c.stop_deceleration;
  l.position_lower = c.position_lower;
  l.position_upper = c.position_upper;
  return l;
}

}  // namespace

Controller::Controller(const SimRobotConfig& config)
    : config_(config),
      dt_(periodOf(config.model)),
      version_(versionOf(config.model)),
      motion_(limitsOf(config), dt_, config.q0),
      actual_q_(config.q0),
      actual_qd_(JointVector::Zero()),
      robot_mode_(rtde::kRobotModeRunning),
      safety_mode_(rtde::kSafetyModeNormal),
      runtime_state_(rtde::kRuntimeStopped),
      scheduled_(config.scheduled_faults) {}

void Controller::log(const std::string& message) const {
  if (config_.verbose) std::fprintf(stderr, "sim-robot [%.3f]: %s\n", timestamp(), message.c_str());
}

void Controller::event(const std::string& s) {
  last_event_ = s;
  log(s);
}

// ---------------------------------------------------------------------------------- state
std::uint32_t Controller::robotStatusBits() const noexcept {
  std::uint32_t b = 0;
  if (robot_mode_ >= rtde::kRobotModePowerOn) b |= rtde::kRobotStatusPowerOn;
  if (runtime_state_ == rtde::kRuntimePlaying) b |= rtde::kRobotStatusProgramRunning;
  return b;
}

std::uint32_t Controller::safetyStatusBits() const noexcept {
  switch (safety_mode_) {
    case rtde::kSafetyModeNormal: return rtde::kSafetyStatusNormal;
    case rtde::kSafetyModeProtectiveStop:
      return rtde::kSafetyStatusProtectiveStopped | rtde::kSafetyStatusStoppedDueToSafety;
    case rtde::kSafetyModeRobotEmergencyStop:
      return rtde::kSafetyStatusRobotEmergencyStopped | rtde::kSafetyStatusEmergencyStopped |
             rtde::kSafetyStatusStoppedDueToSafety;
    case rtde::kSafetyModeSystemEmergencyStop:
      return rtde::kSafetyStatusSystemEmergencyStopped | rtde::kSafetyStatusEmergencyStopped |
             rtde::kSafetyStatusStoppedDueToSafety;
    default: return 0;
  }
}

// ---------------------------------------------------------------------------------- inputs
void Controller::writeInputInt(int index, std::int32_t value) noexcept {
  if (index < 0 || index >= RegisterFile::kWords) return;
  reg_.in_int[static_cast<std::size_t>(index)] = value;
  int_write_tick_[static_cast<std::size_t>(index)] = ticks_;
}

void Controller::writeInputDouble(int index, double value) noexcept {
  if (index < 0 || index >= RegisterFile::kWords) return;
  reg_.in_double[static_cast<std::size_t>(index)] = value;
}

void Controller::writeInputBit(int index, bool value) noexcept {
  if (index < 0 || index >= RegisterFile::kBits) return;
  reg_.in_bit[static_cast<std::size_t>(index)] = value;
}

// ---------------------------------------------------------------------------------- programs
void Controller::loadProgram(const std::string& text) {
  std::istringstream is(text);
  std::string line, name;
  while (std::getline(is, line)) {
    const auto p = line.find_first_not_of(" \t");
    if (p == std::string::npos) continue;
    if (line.compare(p, 4, "def ") == 0) {
      const auto open = line.find('(', p);
      name = line.substr(p + 4, open == std::string::npos ? std::string::npos : open - p - 4);
      break;
    }
  }
  if (name.empty()) {
    log("script port: text without a 'def name():' program ignored");
    return;
  }
  if (robot_mode_ != rtde::kRobotModeRunning || safety_mode_ != rtde::kSafetyModeNormal) {
    event("program '" + name + "' not started: robot_mode " + rtde::robotModeName(robot_mode_) +
          ", safety_mode " + rtde::safetyModeName(safety_mode_));
    return;
  }
  program_text_ = text;
  program_name_ = name;
  program_ = name == ur::kServoProgramName ? ProgramKind::kFtid
             : name == "rtde_control"     ? ProgramKind::kUrRtde
                                          : ProgramKind::kOther;
  offset_ = 0;
  if (program_ == ProgramKind::kUrRtde) {
    // ur_rtde substitutes "global reg_offset_int = # int register offset\n<0|24>".
    const auto k = text.find("reg_offset_int =");
    if (k != std::string::npos) {
      std::size_t p = k + std::strlen("reg_offset_int =");
      while (p < text.size() && text[p] == ' ') ++p;
      if (p < text.size() && text[p] == '#') p = text.find('\n', p) + 1;
      if (p > 0 && p < text.size()) offset_ = std::atoi(text.c_str() + p) == 24 ? 24 : 0;
    }
  } else if (text.find("read_input_integer_register(24)") != std::string::npos) {
    offset_ = 24;
  }
  runtime_state_ = rtde::kRuntimePlaying;
  executing_ = false;
  motion_.endServo();
  motion_.endMoveJ();
  watchdog_armed_ = false;
  watchdog_fired_ = false;
  if (program_ != ProgramKind::kOther) reg_.out_int[static_cast<std::size_t>(offset_)] = ur::kScriptReady;
  if (program_first_start_ < 0) program_first_start_ = timestamp();
  event("program '" + name + "' started (register offset " + std::to_string(offset_) + ")");
}

bool Controller::play() {
  if (program_text_.empty()) return false;
  if (robot_mode_ != rtde::kRobotModeRunning || safety_mode_ != rtde::kSafetyModeNormal) return false;
  const std::string text = program_text_;
  loadProgram(text);
  return true;
}

void Controller::pause() {
  if (runtime_state_ == rtde::kRuntimePlaying) {
    runtime_state_ = rtde::kRuntimePaused;
    motion_.endServo();
    motion_.stop(config_.stop_deceleration);
  }
}

void Controller::stopProgram(const std::string& why) {
  if (runtime_state_ == rtde::kRuntimePlaying || runtime_state_ == rtde::kRuntimePaused) {
    runtime_state_ = rtde::kRuntimeStopping;
    stopping_ticks_ = 1;
    event("program stopped: " + why);
  }
  motion_.endServo();
  motion_.endMoveJ();
  watchdog_armed_ = false;
  motion_.stop(config_.stop_deceleration);
}

void Controller::protectiveStop(const std::string& why) {
  safety_mode_ = rtde::kSafetyModeProtectiveStop;
  stopProgram("protective stop");
  event("protective stop: " + why);
}

void Controller::powerOn() noexcept {
  if (robot_mode_ == rtde::kRobotModePowerOff) robot_mode_ = rtde::kRobotModeIdle;
}

void Controller::powerOff() {
  stopProgram("power off");
  robot_mode_ = rtde::kRobotModePowerOff;
}

void Controller::brakeRelease() noexcept {
  if (robot_mode_ == rtde::kRobotModeIdle || robot_mode_ == rtde::kRobotModePowerOn) {
    robot_mode_ = rtde::kRobotModeRunning;
  }
}

void Controller::unlockProtectiveStop() noexcept {
  if (safety_mode_ == rtde::kSafetyModeProtectiveStop) safety_mode_ = rtde::kSafetyModeNormal;
}

// ---------------------------------------------------------------------------------- faults
void Controller::inject(FaultKind kind, int count) {
  switch (kind) {
    case FaultKind::kProtectiveStop: protectiveStop("injected"); break;
    case FaultKind::kEmergencyStop:
      safety_mode_ = rtde::kSafetyModeRobotEmergencyStop;
      stopProgram("emergency stop");
      robot_mode_ = rtde::kRobotModePowerOff;
      event("emergency stop (injected)");
      break;
    case FaultKind::kProgramStop: stopProgram("injected program stop"); break;
    case FaultKind::kDropPackets:
      drop_remaining_ += std::max(count, 1);
      event("dropping packages (injected)");
      break;
    case FaultKind::kLatePackets:
      late_remaining_ += std::max(count, 1);
      event("delaying packages (injected)");
      break;
    case FaultKind::kDisconnect:
      disconnect_requested_ = true;
      event("disconnecting clients (injected)");
      break;
    case FaultKind::kStallTicks:
      stall_remaining_ += std::max(count, 1);
      event("stalling the clock (injected)");
      break;
  }
}

bool Controller::takeDisconnectRequest() noexcept {
  const bool r = disconnect_requested_;
  disconnect_requested_ = false;
  return r;
}

void Controller::applyScheduledFaults() {
  if (program_first_start_ < 0) return;
  for (auto it = scheduled_.begin(); it != scheduled_.end();) {
    if (timestamp() - program_first_start_ >= it->after_s) {
      inject(it->kind, it->count);
      it = scheduled_.erase(it);
    } else {
      ++it;
    }
  }
}

// Watchdog (UR's rtde_set_watchdog(var, f, "stop")): the watched input must have been written at
// least min_hz times per second, in controller time, while the program plays.
void Controller::checkWatchdog() {
  if (!watchdog_armed_ || runtime_state_ != rtde::kRuntimePlaying || !(watchdog_min_hz_ > 0)) return;
  const double since =
      static_cast<double>(ticks_ - int_write_tick_[static_cast<std::size_t>(watchdog_register_)]) * dt_;
  if (since > 1.0 / watchdog_min_hz_) {
    watchdog_fired_ = true;
    stopProgram("RTDE watchdog: input_int_register_" + std::to_string(watchdog_register_) +
                " not updated for " + std::to_string(since) + " s");
  }
}

// ---------------------------------------------------------------------------------- tick
Controller::TickResult Controller::tick() {
  TickResult r;
  if (stall_remaining_ > 0) {
    --stall_remaining_;
    return r;  // the controller clock does not advance: no packages
  }
  ++ticks_;
  r.advanced = true;
  if (runtime_state_ == rtde::kRuntimeStopping && --stopping_ticks_ < 0) {
    runtime_state_ = rtde::kRuntimeStopped;
  }
  applyScheduledFaults();
  checkWatchdog();
  const JointVector prev_q = motion_.q(), prev_qd = motion_.qd();
  programStep();
  const MotionModel::StepResult m = motion_.step();
  if (m.movej_finished && runtime_state_ == rtde::kRuntimePlaying) {
    reg_.out_int[static_cast<std::size_t>(offset_)] = ur::kScriptDone;
  }
  if (m.position_limit_joint >= 0 && safety_mode_ == rtde::kSafetyModeNormal) {
    protectiveStop("joint " + std::to_string(m.position_limit_joint + 1) + " position limit");
  }
  actual_q_ = prev_q;  // actual lags target by one tick
  actual_qd_ = prev_qd;
  r.drop = drop_remaining_ > 0;
  if (r.drop) --drop_remaining_;
  r.late = late_remaining_ > 0;
  if (r.late) --late_remaining_;
  return r;
}

}  // namespace ftid::simrobot
