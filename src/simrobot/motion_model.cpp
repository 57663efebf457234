#include "ftid/simrobot/motion_model.hpp"

#include <algorithm>
#include <cmath>

namespace ftid::simrobot {

MotionModel::MotionModel(const MotionLimits& limits, double period_s, const JointVector& q0)
    : limits_(limits),
      dt_(period_s),
      q_(q0),
      qd_(JointVector::Zero()),
      qdd_(JointVector::Zero()),
      servo_target_(q0),
      servo_prev_target_(q0),
      servo_t_(period_s),
      stop_decel_(limits.stop_deceleration),
      movej_start_(q0),
      movej_delta_(JointVector::Zero()) {}

void MotionModel::servo(const JointVector& target) noexcept {
  if (!servo_active_) {
    servo_prev_target_ = q_;
    stopping_ = false;
    movej_active_ = false;
  } else {
    servo_prev_target_ = servo_target_;
  }
  servo_target_ = target;
  servo_active_ = true;
}

void MotionModel::setServoParameters(double t, double lookahead, double gain) noexcept {
  if (t > 0) servo_t_ = t;
  if (lookahead > 0) servo_lookahead_ = std::clamp(lookahead, 0.03, 0.2);
  if (gain > 0) servo_gain_ = std::clamp(gain, 100.0, 2000.0);
}

void MotionModel::moveJ(const JointVector& target, double v, double a) noexcept {
  servo_active_ = false;
  stopping_ = false;
  movej_active_ = true;
  movej_start_ = q_;
  movej_delta_ = target - q_;
  movej_distance_ = movej_delta_.cwiseAbs().maxCoeff();
  movej_v_ = v;
  movej_a_ = a;
  movej_t_ = 0.0;
}

void MotionModel::stop(double deceleration) noexcept {
  stopping_ = true;
  stop_decel_ = deceleration > 0 ? deceleration : limits_.stop_deceleration;
}

MotionModel::StepResult MotionModel::step() noexcept {
  StepResult result;
  JointVector acc = JointVector::Zero();
  if (movej_active_) {
    // Trapezoidal profile of the largest joint displacement; all joints scaled to it.
    movej_t_ += dt_;
    const double D = movej_distance_, v = movej_v_, a = movej_a_;
    double s;
    const double t_acc = v / a;
    if (D <= 1e-12) {
      s = 1.0;
    } else if (D < v * t_acc) {  // triangular
      const double tp = std::sqrt(D / a);
      const double t = std::min(movej_t_, 2 * tp);
      s = (t <= tp ? 0.5 * a * t * t : D - 0.5 * a * (2 * tp - t) * (2 * tp - t)) / D;
    } else {
      const double T = D / v + t_acc;
      const double t = std::min(movej_t_, T);
      if (t < t_acc) {
        s = 0.5 * a * t * t;
      } else if (t < T - t_acc) {
        s = 0.5 * a * t_acc * t_acc + v * (t - t_acc);
      } else {
        s = D - 0.5 * a * (T - t) * (T - t);
      }
      s /= D;
    }
    const JointVector q_new = movej_start_ + movej_delta_ * s;
    const JointVector qd_new = (q_new - q_) / dt_;
    acc = (qd_new - qd_) / dt_;
    qdd_ = acc;
    qd_ = qd_new;
    q_ = q_new;
    if (s >= 1.0) {
      movej_active_ = false;
      qd_.setZero();
      result.movej_finished = true;
    }
    return result;
  }
  if (servo_active_) {
    const double omega = std::min(2.0 / servo_lookahead_ * std::sqrt(servo_gain_ / 300.0),
                                  limits_.omega_max_fraction / dt_);
    const double t = std::max(servo_t_, dt_);
    const JointVector v_ff = (servo_target_ - servo_prev_target_) / t;
    acc = omega * omega * (servo_target_ - q_) + 2.0 * omega * (v_ff - qd_);
    servo_prev_target_ = servo_target_;  // a repeated target means "hold": v_ff = 0
  } else if (stopping_) {
    for (int i = 0; i < 6; ++i) {
      const double need = -qd_[i] / dt_;
      acc[i] = std::clamp(need, -stop_decel_, stop_decel_);
    }
    if (qd_.cwiseAbs().maxCoeff() < 1e-9) stopping_ = false;
  } else {
    acc = -qd_ / dt_;  // idle: at rest
  }
  for (int i = 0; i < 6; ++i) {
    acc[i] = std::clamp(acc[i], -limits_.acceleration_limit, limits_.acceleration_limit);
  }
  JointVector qd_new = qd_ + acc * dt_;
  for (int i = 0; i < 6; ++i) {
    qd_new[i] = std::clamp(qd_new[i], -limits_.velocity_limit[i], limits_.velocity_limit[i]);
  }
  qdd_ = (qd_new - qd_) / dt_;
  q_ += 0.5 * (qd_ + qd_new) * dt_;
  qd_ = qd_new;
  for (int i = 0; i < 6; ++i) {
    if (q_[i] < limits_.position_lower[i] || q_[i] > limits_.position_upper[i]) {
      q_[i] = std::clamp(q_[i], limits_.position_lower[i], limits_.position_upper[i]);
      qd_[i] = 0.0;
      if (result.position_limit_joint < 0) result.position_limit_joint = i;
    }
  }
  return result;
}

}  // namespace ftid::simrobot
