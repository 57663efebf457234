#pragma once
// Time-consistent pairing of robot states with sensor samples (docs/daemon.md, "Time base").
//
// The robot is the clock of ftidd's loop, but the F/T+IMU sensor samples faster (up to 1 kHz)
// on its own schedule, so the newest sample can be up to one sensor period older than the robot
// state; paired as is, that shows up in the logs as a spurious `sensor_delay`. Instead:
//
//   RobotClockMap   maps the controller's RTDE timestamp onto the host clock of the sensor's
//                   receive timestamps (CLOCK_REALTIME):
//                     host_us(robot_time) = round(robot_time * 1e6) + offset_us,
//                     offset_us = min over the last one to two windows of
//                                 (recv_utime - round(robot_time * 1e6)),
//                   i.e. the robot state is placed at the time it would have been received with
//                   the smallest RTDE latency seen (jitter of the network and of the loop's
//                   wake-up removed; the minimum latency itself cannot be observed and stays in).
//   SensorHistory   a fixed ring of the most recent samples (every complete sample, not only the
//                   newest), and the sample at a host time by linear interpolation between the
//                   two samples bracketing it, or the nearest one if only one side exists.
//
// Both are fixed size, noexcept and allocation-free (test/rt_safety/rt_daemon_test.cpp).
#include <array>
#include <cstdint>

#include "ftid/common/records.hpp"

namespace ftid::daemon {

/// How SensorHistory::sampleAt produced its sample.
enum class SensorPairing : std::uint8_t {
  kNone,          ///< the history is empty: nothing written
  kInterpolated,  ///< between two samples (or exactly at one): the sample at the requested time
  kNewest,        ///< at or after the newest sample: the newest one (the sensor lags)
  kOldest,        ///< before the oldest sample: the oldest one (the history does not reach back)
};

/// The most recent sensor samples, ordered by receive time (recv_utime, host CLOCK_REALTIME us).
class SensorHistory {
 public:
  /// 128 samples: 128 ms at 1 kHz, far more than one robot period plus RTDE latency jitter.
  static constexpr int kCapacity = 128;

  /// Appends a sample received after the previous one. Ignored if recv_utime <= 0 (no sample).
  /// A sample with the newest sample's receive time replaces it; a sample older than the newest
  /// means the host clock stepped back, and the history restarts with it.
  void push(const SensorSampleRecord& sample) noexcept;
  void clear() noexcept { count_ = 0; }

  int size() const noexcept { return count_; }
  bool empty() const noexcept { return count_ == 0; }
  /// i = 0 is the oldest, size() - 1 the newest. Precondition: 0 <= i < size().
  const SensorSampleRecord& at(int i) const noexcept {
    return ring_[static_cast<std::size_t>((head_ + kCapacity - count_ + i) % kCapacity)];
  }
  const SensorSampleRecord& newest() const noexcept { return at(count_ - 1); }

  /// The sample at host time t_us [us, CLOCK_REALTIME].
  ///   kInterpolated: t0 <= t_us <= t1 for adjacent samples s0, s1 (t = recv_utime):
  ///       values (wrench, IMU, temperature) = (1 - a) s0 + a s1, a = (t_us - t0) / (t1 - t0),
  ///       so that a quantity linear in time is reproduced exactly at t_us; at t_us == t1 the
  ///       sample s1 itself. health_flags = s0 | s1, valid = s0 && s1, has_imu / has_temp =
  ///       s0 && s1; recv_utime, recv_mono_us, counter and status_word are those of s1 (the
  ///       newest sample that contributed: the time the value became available).
  ///       *reach_us = t1 - t0.
  ///   kNewest / kOldest: the nearest sample unchanged, *reach_us = |t_us - its recv_utime|.
  ///   kNone: out and *reach_us untouched.
  SensorPairing sampleAt(std::int64_t t_us, SensorSampleRecord* out,
                         std::int64_t* reach_us) const noexcept;

 private:
  std::array<SensorSampleRecord, kCapacity> ring_{};
  int head_ = 0;   ///< index of the next write
  int count_ = 0;
};

/// Controller time (RTDE timestamp [s]) -> host CLOCK_REALTIME [us], by the minimum observed
/// offset (see the file comment). The minimum is kept over windows of `window_s` controller
/// seconds: the estimate uses the current and the previous window, so a change of the offset
/// (clock drift between controller and host) is followed within two windows.
class RobotClockMap {
 public:
  /// An offset this much above the current estimate [us] is not latency but a step of a clock
  /// (host clock set forward): the estimate restarts from it.
  static constexpr std::int64_t kStepThresholdUs = 250'000;

  explicit RobotClockMap(double window_s = 1.0) noexcept : window_us_(static_cast<std::int64_t>(window_s * 1e6)) {}

  /// Feeds one robot state (controller time [s], host receive time [us]) and returns the host
  /// time [us] of robot_time_s. The estimate restarts if the controller time runs backwards
  /// (controller restarted) or the offset jumps up by more than kStepThresholdUs. A state
  /// without a finite controller time or a receive time (<= 0) is not fed; returns 0.
  std::int64_t update(double robot_time_s, std::int64_t recv_utime) noexcept;

  /// The host time [us] of a controller time with the current estimate (0 before any update).
  std::int64_t hostTimeUs(double robot_time_s) const noexcept;
  bool valid() const noexcept { return valid_; }
  std::int64_t offsetUs() const noexcept;
  /// Restarts of the estimate after the first one (controller restarts, host clock steps).
  std::uint64_t restarts() const noexcept { return restarts_; }

 private:
  void restart(std::int64_t robot_us, std::int64_t offset) noexcept;

  std::int64_t window_us_;
  bool valid_ = false;
  std::int64_t last_robot_us_ = 0;
  std::int64_t window_start_us_ = 0;  ///< controller time at which the current window began
  std::int64_t min_current_ = 0;      ///< minimum offset in the current window
  std::int64_t min_previous_ = 0;     ///< minimum offset in the previous window
  std::uint64_t restarts_ = 0;
};

/// What ControllerClockCheck found wrong with the controller's clock.
enum class ClockFault : std::uint8_t {
  kNone,
  kStopped,    ///< a new state with the same controller time (a frozen RTDE timestamp)
  kBackwards,  ///< the controller time went back (a controller restart, or a broken clock)
  kJump,       ///< it advanced more than the host's elapsed time plus the jump tolerance
  kRate,       ///< over a window it ran faster or slower than the host's monotonic clock
};

/// Checks the controller's clock (the RTDE timestamp) against the host's monotonic clock, so
/// that a stopped, jumping or wrongly running controller clock cannot make ftidd pair stale
/// sensor samples as if they were current (issue 26). While a fault is present and for
/// `recovery_us` of sane states after it, sane() is false and the cycle is invalid. Fixed size,
/// noexcept, allocation-free.
class ControllerClockCheck {
 public:
  struct Options {
    /// A controller time step beyond the host's elapsed time by more than this is a jump [us].
    /// Host-side delays only make the host's elapsed time longer (a state processed late), so
    /// the tolerance only has to cover the receive jitter of one state; 50 ms is 6 periods at
    /// 125 Hz, far beyond the RTDE jitter measured (docs/performance.md).
    std::int64_t jump_tolerance_us = 50'000;
    /// |controller elapsed / host elapsed - 1| above this over a window is a wrong rate. A host
    /// stall of S at a window's end shifts the ratio by S / window: 5 % of a 5 s window is a
    /// 250 ms stall, in which every cycle is stale anyway.
    double rate_tolerance = 0.05;
    std::int64_t rate_window_us = 5'000'000;
    /// Sane for this long (host monotonic time) after a fault before cycles are valid again.
    std::int64_t recovery_us = 500'000;
  };

  ControllerClockCheck() noexcept = default;
  explicit ControllerClockCheck(const Options& options) noexcept : options_(options) {}

  /// Feeds one robot state: controller time [s] and the host's monotonic time [us] now. A
  /// non-finite controller time is not fed (the state is unusable anyway). Returns sane().
  bool update(double robot_time_s, std::int64_t host_mono_us) noexcept;
  bool sane() const noexcept { return sane_; }
  /// Faults detected (each state found faulty counts once).
  std::uint64_t faults() const noexcept { return faults_; }
  ClockFault lastFault() const noexcept { return last_fault_; }

 private:
  Options options_;
  bool have_ = false;
  bool sane_ = true;
  std::int64_t prev_robot_us_ = 0;
  std::int64_t prev_host_us_ = 0;
  std::int64_t window_robot_us_ = 0;
  std::int64_t window_host_us_ = 0;
  std::int64_t sane_since_us_ = 0;
  std::uint64_t faults_ = 0;
  ClockFault last_fault_ = ClockFault::kNone;
};

}  // namespace ftid::daemon
