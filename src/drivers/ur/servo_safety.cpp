#include "ftid/drivers/ur/servo_safety.hpp"

#include <cmath>

namespace ftid::drivers::ur {

const char* servoRejectName(ServoReject r) noexcept {
  switch (r) {
    case ServoReject::kNone: return "accepted";
    case ServoReject::kNonFinite: return "non-finite target";
    case ServoReject::kPositionLimit: return "target outside the joint position limits";
    case ServoReject::kVelocityLimit: return "target step exceeds the joint velocity limit";
    case ServoReject::kAccelerationLimit: return "target step exceeds the joint acceleration limit";
  }
  return "unknown";
}

void ServoSafetyCheck::reset(const JointVector& q, const JointVector& qd) noexcept {
  q_prev_ = q;
  v_prev_ = qd;
  initialised_ = q.allFinite() && qd.allFinite();
  failed_joint_ = -1;
}

ServoReject ServoSafetyCheck::check(const JointVector& q, double dt) noexcept {
  failed_joint_ = -1;
  for (int i = 0; i < kNumJoints; ++i) {
    if (!std::isfinite(q[i])) {
      failed_joint_ = i;
      return ServoReject::kNonFinite;
    }
  }
  for (int i = 0; i < kNumJoints; ++i) {
    if (q[i] < limits_.lower[i] || q[i] > limits_.upper[i]) {
      failed_joint_ = i;
      return ServoReject::kPositionLimit;
    }
  }
  if (!initialised_ || !(dt > 0.0) || !std::isfinite(dt)) {
    failed_joint_ = 0;
    return ServoReject::kVelocityLimit;  // no reference: cannot prove the step is reachable
  }
  JointVector v;
  for (int i = 0; i < kNumJoints; ++i) {
    v[i] = (q[i] - q_prev_[i]) / dt;
    if (std::abs(v[i]) > limits_.velocity[i]) {
      failed_joint_ = i;
      return ServoReject::kVelocityLimit;
    }
  }
  for (int i = 0; i < kNumJoints; ++i) {
    if (std::abs(v[i] - v_prev_[i]) / dt > limits_.acceleration[i]) {
      failed_joint_ = i;
      return ServoReject::kAccelerationLimit;
    }
  }
  q_prev_ = q;
  v_prev_ = v;
  return ServoReject::kNone;
}

}  // namespace ftid::drivers::ur
