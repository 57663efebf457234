#pragma once
// A Universal Robots controller simulator on loopback (docs/robot.md, "Simulator"):
//  - RTDE server (protocol v1/v2, several clients, per-connection input ownership, output
//    decimation floor(f_ctrl / f_req)), faithful enough for ur_rtde 1.6.5 and UR's Python client;
//  - dashboard server subset (exact reply texts of UR's dashboard server, docs/robot.md) plus `sim ...`
//    fault-injection commands;
//  - script port: accepts a program text, recognises ftid's `def ftid_servo():` and ur_rtde's
//    `def rtde_control():` by header and emulates their register protocol (commands 0, 1 moveJ,
//    11 servoJ, 16 servoStop, 26 step time, 35 watchdog, 255 stop);
//  - a tick thread with absolute deadlines; `timestamp` = t0 + n * period exactly.
// Joint motion follows servoj through a documented second-order tracking model with velocity
// and acceleration limits (SimRobotConfig). All public methods are thread-safe.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "ftid/common/types.hpp"

namespace ftid::simrobot {

enum class RobotModel : std::uint8_t {
  kUR10,   ///< CB3, software 3.15.8.106339, 125 Hz
  kUR10e,  ///< e-Series, software 5.11.1.108318, 500 Hz
};
/// "ur10" / "ur10e" (case-insensitive). Throws ConfigError otherwise.
RobotModel parseRobotModel(const std::string& name);

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
  double t0 = 50.0;  ///< timestamp of the first tick [s] (> 40 s, like a controller that has been up a while)
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

/// What a test or the CLI can observe.
struct SimSnapshot {
  double timestamp = 0.0;
  std::uint64_t ticks = 0;
  JointVector q = JointVector::Zero();   ///< target_q (the model state)
  JointVector qd = JointVector::Zero();
  JointVector actual_q = JointVector::Zero();
  std::int32_t robot_mode = 0;
  std::int32_t safety_mode = 0;
  std::uint32_t runtime_state = 0;
  std::string program_name;   ///< "" if none was ever loaded
  bool servo_active = false;
  bool moving = false;        ///< any |qd| > 1e-6
  int rtde_connections = 0;
  std::uint64_t servo_commands = 0;   ///< servoJ ticks processed
  std::uint64_t packages_sent = 0;
  std::uint64_t packages_dropped = 0;
  bool watchdog_armed = false;
  bool watchdog_fired = false;
  std::string last_event;     ///< last notable event ("protective stop: ...", "program stopped")
};

class SimRobot {
 public:
  explicit SimRobot(SimRobotConfig config);
  ~SimRobot();
  SimRobot(const SimRobot&) = delete;
  SimRobot& operator=(const SimRobot&) = delete;

  /// Binds the three ports and starts the tick and I/O threads. Throws DriverError if a port is busy.
  void start();
  /// Stops the threads and closes every socket. Idempotent.
  void stop();

  std::uint16_t rtdePort() const noexcept;
  std::uint16_t dashboardPort() const noexcept;
  std::uint16_t scriptPort() const noexcept;
  double period() const noexcept;  ///< 0.008 or 0.002
  std::string versionString() const;  ///< "3.15.8.106339" / "5.11.1.108318"

  /// Fault injection (effective at the next tick).
  void inject(FaultKind kind, int count = 10);
  /// Loads and starts a program text exactly as if it arrived on the script port.
  void runProgramText(const std::string& text);

  SimSnapshot snapshot() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

/// UR DH forward kinematics: actual_TCP_pose = [x, y, z, rx, ry, rz] in the controller base frame
/// (zero TCP offset). Exposed for tests.
Vec6 forwardKinematicsTcpPose(RobotModel model, const JointVector& q);

}  // namespace ftid::simrobot
