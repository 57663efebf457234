#pragma once
// Last-hop check of servo targets (docs/robot.md). Pure and real-time safe.
// A target q_k passes when: every element is finite; lower <= q_k <= upper; the implied velocity
// v_k = (q_k - q_{k-1}) / dt is within the velocity limit; and the implied acceleration
// (v_k - v_{k-1}) / dt is within the acceleration limit. The reference (q_{k-1}, v_{k-1}) is the
// last ACCEPTED target, so a rejected target does not move the reference (the arm is held there).
#include <cstdint>

#include "ftid/common/status.hpp"
#include "ftid/common/types.hpp"

namespace ftid::drivers::ur {

struct ServoLimits {
  JointVector lower = JointVector::Constant(-6.283185307179586);  ///< [rad]
  JointVector upper = JointVector::Constant(6.283185307179586);   ///< [rad]
  /// UR10/UR10e: 120 deg/s base/shoulder, 180 deg/s elbow and wrists (UR10/UR10e joint speed limits, docs/robot.md).
  JointVector velocity = (JointVector() << 2.0944, 2.0944, 3.1416, 3.1416, 3.1416, 3.1416).finished();
  JointVector acceleration = JointVector::Constant(40.0);  ///< [rad/s^2] (ur_rtde client bound)
};

/// Why a target was refused (first failing check).
enum class ServoReject : std::uint8_t { kNone, kNonFinite, kPositionLimit, kVelocityLimit, kAccelerationLimit };
const char* servoRejectName(ServoReject r) noexcept;

class ServoSafetyCheck {
 public:
  ServoSafetyCheck() = default;
  explicit ServoSafetyCheck(const ServoLimits& limits) : limits_(limits) {}
  /// Sets the reference to the current robot state (at rest or moving with qd).
  void reset(const JointVector& q, const JointVector& qd = JointVector::Zero()) noexcept;
  /// Checks q for a step of dt seconds; on success it becomes the new reference.
  ServoReject check(const JointVector& q, double dt) noexcept;
  const JointVector& lastTarget() const noexcept { return q_prev_; }
  bool initialised() const noexcept { return initialised_; }
  /// Joint index of the last failure (-1 if none).
  int failedJoint() const noexcept { return failed_joint_; }
  const ServoLimits& limits() const noexcept { return limits_; }

 private:
  ServoLimits limits_{};
  JointVector q_prev_ = JointVector::Zero();
  JointVector v_prev_ = JointVector::Zero();
  bool initialised_ = false;
  int failed_joint_ = -1;
};

}  // namespace ftid::drivers::ur
