#pragma once
// The arm seam (docs/architecture.md): the loop talks to an Arm, production uses RtdeArm, tests use
// fakes. Every method is real-time safe (noexcept, no allocation).
#include <chrono>
#include <cstdint>

#include "ftid/common/status.hpp"
#include "ftid/common/types.hpp"

namespace ftid::drivers::ur {

/// One controller tick as the loop sees it.
struct ArmState {
  double timestamp = 0.0;  ///< controller time [s]
  JointVector q = JointVector::Zero();           ///< actual_q [rad]
  JointVector qd = JointVector::Zero();          ///< actual_qd [rad/s]
  JointVector target_q = JointVector::Zero();    ///< [rad]
  JointVector target_qd = JointVector::Zero();   ///< [rad/s]
  JointVector target_qdd = JointVector::Zero();  ///< [rad/s^2]
  Vec6 tcp_pose = Vec6::Zero();  ///< actual_TCP_pose: x y z [m], rotation vector [rad]
  std::int32_t robot_mode = -1;
  std::int32_t safety_mode = 0;
  std::uint32_t runtime_state = 0;
  std::uint32_t robot_status_bits = 0;
  std::uint32_t safety_status_bits = 0;
  std::int32_t script_state = 0;  ///< output_int_register_<offset>: 1 ready, 2 done
  double speed_scaling = 1.0;
  std::int64_t host_receive_ns = 0;    ///< CLOCK_MONOTONIC [ns]
  std::uint32_t packages_skipped = 0;  ///< ticks lost before this one (drain + timestamp gaps)
};

class Arm {
 public:
  virtual ~Arm() = default;
  /// Blocks for the next controller tick. kOk, kTimeout (a missed cycle) or kFault (link lost).
  virtual Status waitForState(std::chrono::nanoseconds timeout, ArmState* out) noexcept = 0;
  /// Last-hop checked servo target (finite, within position limits, reachable from the previous
  /// target within velocity/acceleration limits). On rejection nothing new is sent, the arm is
  /// held at the previous target, kRejected is returned and a fault bit is raised.
  virtual Status sendServoTarget(const JointVector& q) noexcept = 0;
  /// Re-sends the previous target (keeps the watchdog fed, holds the arm).
  virtual Status sendHold() noexcept = 0;
  /// Asks the controller to stop servoing (decelerate to rest). Non-blocking.
  virtual Status sendServoStop() noexcept = 0;
  /// Asks the robot program to arm its RTDE watchdog (ftid's servo program: command 35 with the
  /// configured minimum frequency; the program stops itself, and so the arm, when the command
  /// register is not written that often). Non-blocking: the loop repeats it every tick until the
  /// state's script_state shows the program done with it (2), then clears it with
  /// sendClearCommand() until the program is ready again (1). Sent only from the real-time loop's
  /// first cycles, so no stall of a non-real-time thread can fire the watchdog.
  virtual Status sendArmWatchdog() noexcept = 0;
  /// Clears a finished non-real-time command (command 0; the program answers ready, 1).
  virtual Status sendClearCommand() noexcept = 0;
  /// Re-bases the last-hop check (previous target and velocity) on the robot's current state;
  /// call before streaming starts. The held target becomes q.
  virtual void resetServoReference(const JointVector& q, const JointVector& qd) noexcept = 0;
  /// Controller period [s] (0.008 CB3, 0.002 e-Series).
  virtual double period() const noexcept = 0;
};

}  // namespace ftid::drivers::ur
