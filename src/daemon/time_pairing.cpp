#include "ftid/daemon/time_pairing.hpp"

#include <algorithm>
#include <cmath>

namespace ftid::daemon {

namespace {

// (1 - a) x0 + a x1 (0 < a < 1 here: a time equal to a sample's returns that sample).
template <class V>
V lerp(const V& x0, const V& x1, double a) noexcept {
  return x0 + a * (x1 - x0);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
void SensorHistory::push(const SensorSampleRecord& sample) noexcept {
  if (sample.recv_utime <= 0) return;
  if (count_ > 0) {
    const std::int64_t newest_t = newest().recv_utime;
    if (sample.recv_utime == newest_t) {
      ring_[static_cast<std::size_t>((head_ + kCapacity - 1) % kCapacity)] = sample;
      return;
    }
    if (sample.recv_utime < newest_t) count_ = 0;  // the host clock stepped back
  }
  ring_[static_cast<std::size_t>(head_)] = sample;
  head_ = (head_ + 1) % kCapacity;
  count_ = std::min(count_ + 1, kCapacity);
}

SensorPairing SensorHistory::sampleAt(std::int64_t t_us, SensorSampleRecord* out,
                                      std::int64_t* reach_us) const noexcept {
  if (count_ == 0) return SensorPairing::kNone;
  const SensorSampleRecord& last = newest();
  if (t_us > last.recv_utime) {
    *out = last;
    *reach_us = t_us - last.recv_utime;
    return SensorPairing::kNewest;
  }
  // Newest first: the robot state's time is normally within the last sensor period or two.
  int i1 = count_ - 1;
  while (i1 > 0 && at(i1 - 1).recv_utime >= t_us) --i1;
  const SensorSampleRecord& s1 = at(i1);
  if (s1.recv_utime == t_us) {
    *out = s1;
    *reach_us = 0;
    return SensorPairing::kInterpolated;
  }
  if (i1 == 0) {  // t_us before the oldest sample
    *out = s1;
    *reach_us = s1.recv_utime - t_us;
    return SensorPairing::kOldest;
  }
  const SensorSampleRecord& s0 = at(i1 - 1);
  const std::int64_t span = s1.recv_utime - s0.recv_utime;  // > 0: push keeps times increasing
  const double a = static_cast<double>(t_us - s0.recv_utime) / static_cast<double>(span);
  out->recv_utime = s1.recv_utime;
  out->recv_mono_us = s1.recv_mono_us;  // the age is that of the newer sample used
  out->counter = s1.counter;
  out->status_word = s1.status_word;
  out->wrench_S = lerp(s0.wrench_S, s1.wrench_S, a);
  out->has_imu = s0.has_imu && s1.has_imu;
  if (out->has_imu) {
    out->imu_acc_S = lerp(s0.imu_acc_S, s1.imu_acc_S, a);
    out->imu_w_S = lerp(s0.imu_w_S, s1.imu_w_S, a);
    out->imu_alpha_S = lerp(s0.imu_alpha_S, s1.imu_alpha_S, a);
  } else {
    out->imu_acc_S.setZero();
    out->imu_w_S.setZero();
    out->imu_alpha_S.setZero();
  }
  out->has_temp = s0.has_temp && s1.has_temp;
  out->temp_degC = out->has_temp ? lerp(s0.temp_degC, s1.temp_degC, a) : 0.0;
  out->health_flags = s0.health_flags | s1.health_flags;
  out->valid = s0.valid && s1.valid;
  *reach_us = span;
  return SensorPairing::kInterpolated;
}

// ---------------------------------------------------------------------------------------------
void RobotClockMap::restart(std::int64_t robot_us, std::int64_t offset) noexcept {
  if (valid_) ++restarts_;
  valid_ = true;
  window_start_us_ = robot_us;
  min_current_ = offset;
  min_previous_ = offset;
}

std::int64_t RobotClockMap::update(double robot_time_s, std::int64_t recv_utime) noexcept {
  if (!std::isfinite(robot_time_s) || recv_utime <= 0 || std::fabs(robot_time_s) > 1e12) return 0;
  const std::int64_t robot_us = std::llround(robot_time_s * 1e6);
  const std::int64_t offset = recv_utime - robot_us;
  if (!valid_ || robot_us < last_robot_us_ || offset - offsetUs() > kStepThresholdUs) {
    restart(robot_us, offset);
  } else {
    if (robot_us - window_start_us_ >= window_us_) {  // a new window: forget the oldest minimum
      min_previous_ = min_current_;
      min_current_ = offset;
      window_start_us_ = robot_us;
    } else {
      min_current_ = std::min(min_current_, offset);
    }
  }
  last_robot_us_ = robot_us;
  return robot_us + offsetUs();
}

std::int64_t RobotClockMap::offsetUs() const noexcept {
  return valid_ ? std::min(min_current_, min_previous_) : 0;
}

std::int64_t RobotClockMap::hostTimeUs(double robot_time_s) const noexcept {
  if (!valid_ || !std::isfinite(robot_time_s)) return 0;
  return std::llround(robot_time_s * 1e6) + offsetUs();
}

bool ControllerClockCheck::update(double robot_time_s, std::int64_t host_mono_us) noexcept {
  if (!std::isfinite(robot_time_s) || std::abs(robot_time_s) > 1e12) return sane_;
  const auto robot_us = static_cast<std::int64_t>(std::llround(robot_time_s * 1e6));
  if (!have_) {
    have_ = true;
    prev_robot_us_ = window_robot_us_ = robot_us;
    prev_host_us_ = window_host_us_ = host_mono_us;
    return sane_;
  }
  const std::int64_t d_robot = robot_us - prev_robot_us_;
  const std::int64_t d_host = host_mono_us - prev_host_us_;
  prev_robot_us_ = robot_us;
  prev_host_us_ = host_mono_us;
  ClockFault fault = ClockFault::kNone;
  if (d_robot == 0) {
    fault = ClockFault::kStopped;
  } else if (d_robot < 0) {
    fault = ClockFault::kBackwards;
  } else if (d_robot > d_host + options_.jump_tolerance_us) {
    fault = ClockFault::kJump;
  } else if (host_mono_us - window_host_us_ >= options_.rate_window_us) {
    const double ratio = static_cast<double>(robot_us - window_robot_us_) /
                         static_cast<double>(host_mono_us - window_host_us_);
    if (std::abs(ratio - 1.0) > options_.rate_tolerance) fault = ClockFault::kRate;
    window_robot_us_ = robot_us;
    window_host_us_ = host_mono_us;
  }
  if (fault != ClockFault::kNone) {
    ++faults_;
    last_fault_ = fault;
    sane_ = false;
    sane_since_us_ = host_mono_us;
    window_robot_us_ = robot_us;  // the rate is measured afresh from here
    window_host_us_ = host_mono_us;
    return false;
  }
  if (!sane_ && host_mono_us - sane_since_us_ >= options_.recovery_us) sane_ = true;
  return sane_;
}

}  // namespace ftid::daemon
