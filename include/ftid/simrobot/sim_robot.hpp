#pragma once
// A Universal Robots controller simulator on loopback (docs/robot.md, "Simulator";
// docs/simulator.md, "UR controller simulator"), composed of
//  - the controller model (controller.hpp: modes, programs and their register protocol, motion
//    model, watchdog, faults), socket-free;
//  - an RTDE server (protocol v1/v2, several clients, per-connection input ownership, output
//    decimation floor(f_ctrl / f_req)), faithful enough for ur_rtde 1.6.5 and UR's Python client;
//  - dashboard server subset (exact reply texts of UR's dashboard server, docs/robot.md) plus `sim ...`
//    fault-injection commands;
//  - a script port that loads program texts into the controller;
//  - a tick thread on rt::runTimerClocked; `timestamp` = t0 + n * period exactly.
// All public methods are thread-safe.
#include <cstdint>
#include <memory>
#include <string>

#include "ftid/common/types.hpp"
#include "ftid/rt/loop_stats.hpp"
#include "ftid/simrobot/sim_config.hpp"
#include "ftid/simrobot/ur_model.hpp"

namespace ftid::simrobot {

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
  /// Statistics of the tick thread (wake-up latency against its deadlines = the jitter of the
  /// state stream at the source; compute = one tick with its output packages). Updated about
  /// once a second while running, complete after stop().
  rt::LoopStats tickStats() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace ftid::simrobot
