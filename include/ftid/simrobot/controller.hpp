#pragma once
// The UR controller model of the simulator, without sockets (docs/simulator.md, "UR controller
// simulator"): robot and safety modes, the loaded program and its register protocol (ftid's
// `ftid_servo` and ur_rtde's `rtde_control`), the motion model, the program's RTDE watchdog and
// injected faults. tick() advances one controller period. The servers (RTDE, dashboard, script
// port) talk to it through the narrow interface below; tests drive it directly.
//
// Not thread-safe: SimRobot serialises every call with its own mutex.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "ftid/common/types.hpp"
#include "ftid/drivers/ur/rtde_protocol.hpp"
#include "ftid/simrobot/motion_model.hpp"
#include "ftid/simrobot/sim_config.hpp"

namespace ftid::simrobot {

/// The general-purpose RTDE registers (UR: 48 int, 48 double, 128 bit per direction; the upper
/// half, 24..47 / 64..127, is the range ur_rtde uses with its register offset 24).
struct RegisterFile {
  static constexpr int kWords = 48;
  static constexpr int kBits = 128;
  std::array<std::int32_t, kWords> in_int{};
  std::array<double, kWords> in_double{};
  std::array<bool, kBits> in_bit{};
  std::array<std::int32_t, kWords> out_int{};
  std::array<double, kWords> out_double{};
  std::array<bool, kBits> out_bit{};
};

/// Which program the controller runs (recognised by its `def name():` header).
enum class ProgramKind : std::uint8_t { kNone, kFtid, kUrRtde, kOther };

class Controller {
 public:
  explicit Controller(const SimRobotConfig& config);

  // ------------------------------------------------------------------ clock
  struct TickResult {
    bool advanced = false;  ///< false: the clock is stalled (injected), no output this tick
    bool drop = false;      ///< this tick's output packages are to be dropped (injected)
    bool late = false;      ///< this tick's output packages are to be held back (injected)
  };
  /// One controller period: scheduled faults, the program's watchdog, one program step (the
  /// register protocol), one motion step; actual_q/qd are the target values one tick earlier.
  TickResult tick();
  double period() const noexcept { return dt_; }  ///< 0.008 (UR10) or 0.002 (UR10e) s
  /// Controller time: t0 + ticks * period exactly.
  double timestamp() const noexcept { return config_.t0 + static_cast<double>(ticks_) * dt_; }
  std::uint64_t ticks() const noexcept { return ticks_; }
  const SimRobotConfig& config() const noexcept { return config_; }
  const drivers::ur::rtde::ControllerVersion& version() const noexcept { return version_; }

  // ------------------------------------------------------------------ state
  const MotionModel& motion() const noexcept { return motion_; }  ///< target_q, target_qd, ...
  const JointVector& actualQ() const noexcept { return actual_q_; }
  const JointVector& actualQd() const noexcept { return actual_qd_; }
  std::int32_t robotMode() const noexcept { return robot_mode_; }
  std::int32_t safetyMode() const noexcept { return safety_mode_; }
  std::uint32_t runtimeState() const noexcept { return runtime_state_; }
  std::uint32_t robotStatusBits() const noexcept;
  std::uint32_t safetyStatusBits() const noexcept;
  const RegisterFile& registers() const noexcept { return reg_; }
  ProgramKind programKind() const noexcept { return program_; }
  const std::string& programName() const noexcept { return program_name_; }  ///< "" if none
  bool hasProgram() const noexcept { return !program_text_.empty(); }
  int registerOffset() const noexcept { return offset_; }  ///< 0 or 24
  bool watchdogArmed() const noexcept { return watchdog_armed_; }
  bool watchdogFired() const noexcept { return watchdog_fired_; }
  std::uint64_t servoCommands() const noexcept { return servo_commands_; }
  const std::string& lastEvent() const noexcept { return last_event_; }

  // ------------------------------------------------------------------ RTDE inputs
  /// A register written by an RTDE input package (out-of-range indices are ignored). Every write
  /// counts as an update for the program's watchdog, a repeated value too.
  void writeInputInt(int index, std::int32_t value) noexcept;
  void writeInputDouble(int index, double value) noexcept;
  void writeInputBit(int index, bool value) noexcept;

  // ------------------------------------------------------------------ program control
  /// A program text as it arrives on the script port: the first `def name():` names it; it
  /// starts if robot_mode is RUNNING and safety_mode NORMAL (otherwise an event says why not).
  void loadProgram(const std::string& text);
  /// Dashboard `play`: restarts the loaded program. False if there is none or the robot is not
  /// RUNNING/NORMAL.
  bool play();
  void pause();  ///< dashboard `pause`: PAUSED, servo following ends, the arm decelerates
  void stopProgram(const std::string& why);  ///< STOPPING then STOPPED, the arm decelerates
  void powerOn() noexcept;
  void powerOff();
  void brakeRelease() noexcept;
  void unlockProtectiveStop() noexcept;
  /// Fault injection, effective at the next tick (docs/robot.md §4.2).
  void inject(FaultKind kind, int count);
  /// True once after an injected disconnect: the servers close their RTDE and dashboard clients.
  bool takeDisconnectRequest() noexcept;

  /// Logs to stderr with the controller time when config().verbose.
  void log(const std::string& message) const;

 private:
  void event(const std::string& s);
  void protectiveStop(const std::string& why);
  void applyScheduledFaults();
  void checkWatchdog();
  void programStep();                 // program_interpreter.cpp
  void servoCommand(int o);           // program_interpreter.cpp
  bool nonRealtimeCommand(int o, std::int32_t cmd);  // program_interpreter.cpp

  SimRobotConfig config_;
  double dt_;
  drivers::ur::rtde::ControllerVersion version_;
  std::uint64_t ticks_ = 0;
  MotionModel motion_;
  JointVector actual_q_, actual_qd_;
  std::int32_t robot_mode_;
  std::int32_t safety_mode_;
  std::uint32_t runtime_state_;
  int stopping_ticks_ = 0;
  // program
  ProgramKind program_ = ProgramKind::kNone;
  std::string program_name_;
  std::string program_text_;
  int offset_ = 0;
  bool executing_ = false;
  std::uint64_t servo_change_tick_ = 0;  // tick at which the servo target last changed
  std::uint64_t servo_commands_ = 0;
  // watchdog
  bool watchdog_armed_ = false, watchdog_fired_ = false;
  int watchdog_register_ = 0;  // input_int_register_<this>
  double watchdog_min_hz_ = 0.0;
  std::array<std::uint64_t, RegisterFile::kWords> int_write_tick_{};
  RegisterFile reg_;
  // faults
  int drop_remaining_ = 0, late_remaining_ = 0, stall_remaining_ = 0;
  bool disconnect_requested_ = false;
  std::vector<ScheduledFault> scheduled_;
  double program_first_start_ = -1.0;
  std::string last_event_;
};

}  // namespace ftid::simrobot
