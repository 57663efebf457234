#pragma once
// ftid's own URScript servo program and its upload over the script port (30003).
//
// Register protocol (same layout as ur_rtde for the servo subset so one emulator serves both;
// `o` is the register offset, 0 or 24):
//   input_int_register_o       command: 0 none, 11 servoJ, 16 servoStop, 35 set watchdog, 255 stop
//   input_double_register_o+0..5  q [rad]; +6 v, +7 a (unused by servoj); +8 t [s]; +9 lookahead [s];
//                                 +10 gain. For 16: +0 deceleration [rad/s^2]. For 35: +0 min frequency [Hz]
//   output_int_register_o      1 ready for command / 2 done with (non-real-time) command
//   output_int_register_o+1    count of servo set-points taken (wraps), a heartbeat
// Full text and semantics: docs/robot.md.
#include <chrono>
#include <cstdint>
#include <string>

namespace ftid::drivers::ur {

inline constexpr std::uint16_t kScriptPort = 30003;
inline constexpr const char* kServoProgramName = "ftid_servo";

enum ServoCommand : std::int32_t {
  kCmdNone = 0,
  kCmdMoveJ = 1,
  kCmdServoJ = 11,
  kCmdServoStop = 16,
  kCmdSetWatchdog = 35,
  kCmdStopScript = 255,
};
inline constexpr std::int32_t kScriptReady = 1;
inline constexpr std::int32_t kScriptDone = 2;

struct ServoProgramConfig {
  int register_offset = 0;      ///< 0 or 24
  double step_time = 0.008;     ///< servoj t [s]: controller period
  double lookahead_time = 0.1;  ///< [s], 0.03..0.2
  double gain = 300.0;          ///< 100..2000
};

/// The program text ("def ftid_servo():" ... "end\n"). Throws ConfigError on out-of-range values.
std::string buildServoProgram(const ServoProgramConfig& config);

/// Connects to host:port, writes the whole text, closes. Throws DriverError.
void uploadScript(const std::string& host, std::uint16_t port, const std::string& text,
                  std::chrono::milliseconds timeout = std::chrono::milliseconds(2000));

}  // namespace ftid::drivers::ur
