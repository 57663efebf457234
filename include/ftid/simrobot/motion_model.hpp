#pragma once
// The simulated arm's joint motion (docs/robot.md §4.1, "Tracking model"): servoJ following with a
// critically damped second-order filter and feed-forward, a synchronised trapezoidal moveJ, a
// controlled stop, acceleration / speed / position limits. One step() per controller period.
// No sockets, no program logic (Controller decides what to command); allocation-free.
#include <cstdint>

#include "ftid/common/types.hpp"

namespace ftid::simrobot {

struct MotionLimits {
  double omega_max_fraction = 0.4;   ///< servo bandwidth cap: omega <= this / period
  JointVector velocity_limit = JointVector::Constant(3.1416);  ///< [rad/s]
  double acceleration_limit = 40.0;  ///< [rad/s^2], all joints
  double stop_deceleration = 10.0;   ///< [rad/s^2], stop() with a non-positive argument
  JointVector position_lower = JointVector::Constant(-6.283185307179586);
  JointVector position_upper = JointVector::Constant(6.283185307179586);
};

class MotionModel {
 public:
  MotionModel(const MotionLimits& limits, double period_s, const JointVector& q0);

  /// A servoJ target for this tick. The first target of a servo run takes the current q as the
  /// previous target (no feed-forward jump); it cancels a moveJ and a stop in progress.
  void servo(const JointVector& target) noexcept;
  /// servoj's t, lookahead and gain; a non-positive value keeps the current one. Lookahead is
  /// clamped to [0.03, 0.2] s, gain to [100, 2000] (UR's ranges).
  void setServoParameters(double t, double lookahead, double gain) noexcept;
  /// Synchronised trapezoidal joint move (largest displacement at speed v, acceleration a).
  void moveJ(const JointVector& target, double v, double a) noexcept;
  /// Ends servo following (the arm is then stopped by stop() or held idle).
  void endServo() noexcept { servo_active_ = false; }
  void endMoveJ() noexcept { movej_active_ = false; }
  /// Decelerate every joint to rest at <= deceleration (<= 0: the configured stop deceleration).
  void stop(double deceleration) noexcept;

  struct StepResult {
    bool movej_finished = false;  ///< a moveJ reached its target in this step
    int position_limit_joint = -1;  ///< first joint (0-based) that hit its position limit, or -1
  };
  /// Advances one period.
  StepResult step() noexcept;

  const JointVector& q() const noexcept { return q_; }
  const JointVector& qd() const noexcept { return qd_; }
  const JointVector& qdd() const noexcept { return qdd_; }
  bool servoActive() const noexcept { return servo_active_; }
  bool moveJActive() const noexcept { return movej_active_; }
  bool stopping() const noexcept { return stopping_; }
  const JointVector& servoTarget() const noexcept { return servo_target_; }
  double servoStepTime() const noexcept { return servo_t_; }
  double period() const noexcept { return dt_; }

 private:
  MotionLimits limits_;
  double dt_;
  JointVector q_, qd_, qdd_;
  bool servo_active_ = false;
  JointVector servo_target_, servo_prev_target_;
  double servo_t_, servo_lookahead_ = 0.1, servo_gain_ = 300.0;
  bool stopping_ = false;
  double stop_decel_;
  bool movej_active_ = false;
  JointVector movej_start_, movej_delta_;
  double movej_distance_ = 0.0, movej_v_ = 1.05, movej_a_ = 1.4, movej_t_ = 0.0;
};

}  // namespace ftid::simrobot
