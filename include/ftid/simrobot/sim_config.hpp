#pragma once
// Configuration of the UR controller simulator (docs/robot.md, "Simulator"): the controller model
// (Controller) reads the model, motion and fault fields; SimRobot also the network fields.
#include <cstdint>
#include <string>
#include <vector>

#include "ftid/common/types.hpp"
#include "ftid/simrobot/ur_model.hpp"

namespace ftid::simrobot {

enum class FaultKind : std::uint8_t {
  kProtectiveStop,  ///< safety_mode 3, program stopped, arm brought to rest
  kEmergencyStop,   ///< safety_mode 7 (robot e-stop), program stopped, arm brought to rest, power off
  kProgramStop,     ///< the running program stops (as if "stop" was pressed)
  kDropPackets,     ///< the next `count` output packages are not sent (timestamps jump)
  kLatePackets,     ///< the next `count` output packages are held back and then sent in a burst
  kDisconnect,      ///< every RTDE and dashboard connection is closed by the controller
  kStallTicks,      ///< the controller clock stops for `count` ticks (no packages at all)
};
/// "protective_stop", "estop", "program_stop", "drop", "late", "disconnect", "stall".
FaultKind parseFaultKind(const std::string& name);
const char* faultKindName(FaultKind kind) noexcept;

struct ScheduledFault {
  double after_s = 1.0;  ///< seconds of controller time after a program first starts running
  FaultKind kind = FaultKind::kProtectiveStop;
  int count = 10;        ///< packages for kDropPackets / kLatePackets / kStallTicks
};

struct SimRobotConfig {
  RobotModel model = RobotModel::kUR10;
  std::string host = "127.0.0.1";
  std::uint16_t rtde_port = 30004;       ///< 0: pick a free port (see rtdePort())
  std::uint16_t dashboard_port = 29999;  ///< 0: pick a free port
  std::uint16_t script_port = 30003;     ///< 0: pick a free port
  /// Initial joint angles [rad] (a typical "home": elbow up, tool down).
  JointVector q0 = (JointVector() << 0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0).finished();
  double t0 = 50.0;  ///< timestamp of the first tick [s] (> 40 s, see notes §1.6)
  /// Servo tracking model: omega = 2 / lookahead * sqrt(gain / 300), capped at
  /// omega_max_fraction / period; qdd = omega^2 (q_cmd - q) + 2 omega (v_ff - qd).
  double omega_max_fraction = 0.4;
  JointVector velocity_limit =
      (JointVector() << 2.0944, 2.0944, 3.1416, 3.1416, 3.1416, 3.1416).finished();  ///< [rad/s]
  double acceleration_limit = 40.0;  ///< [rad/s^2], all joints
  double stop_deceleration = 10.0;   ///< [rad/s^2] for protective stop / program stop
  /// A servo target implying more than velocity_limit * this factor from the previous target
  /// raises a protective stop (0 disables the check).
  double servo_step_protective_stop_factor = 1.0;
  JointVector position_lower = JointVector::Constant(-6.283185307179586);
  JointVector position_upper = JointVector::Constant(6.283185307179586);
  bool realtime = true;  ///< tick thread paced by CLOCK_MONOTONIC (false: as fast as possible, tests)
  /// > 0: run the tick thread at SCHED_FIFO with this priority and the I/O thread one below, as
  /// a real controller would (silently stays SCHED_OTHER without the privilege). 0: normal threads.
  int thread_priority = 0;
  std::string serial_number = "20185500000";
  std::vector<ScheduledFault> scheduled_faults;
  bool verbose = false;  ///< log connections/programs to stderr
};

}  // namespace ftid::simrobot
