#pragma once
// The seams ftidd's cycle is written against (docs/architecture.md): one per piece of hardware and
// one for each piece of math, so that a whole cycle runs in a unit test against fakes. The
// production implementations are thin adapters (ftid/daemon/adapters.hpp) over the UR RTDE
// client, the CAN sensor, RobotKinematics and the compensator. Every method the loop calls is
// noexcept, allocation-free and non-blocking (except waitForState, which is the loop's clock).
#include <chrono>
#include <cstdint>
#include <limits>

#include "ftid/common/status.hpp"
#include "ftid/common/types.hpp"
#include "ftid/daemon/time_pairing.hpp"
#include "ftid/effects/effect.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/common/records.hpp"

namespace ftid::daemon {

/// The robot is the clock: waitForState() blocks until the next state packet (or the timeout).
class ArmStateSource {
 public:
  virtual ~ArmStateSource() = default;
  /// kOk (out filled, out->valid tells whether the values are usable), kTimeout, or kFault
  /// (connection lost). Real-time safe.
  virtual Status waitForState(std::chrono::nanoseconds timeout,
                              RobotStateRecord* out) noexcept = 0;
  /// True if the last state reported a protective/emergency stop or a stopped program.
  virtual bool robotStopped() const noexcept { return false; }
  /// State packets the source dropped since start because a newer one was already waiting
  /// (drain-to-latest: the loop fell behind). Any thread may read it.
  virtual std::uint64_t packetsSkipped() const noexcept { return 0; }
  /// Why the last waitForState() failed (static text, for messages; "" if unknown). Non-RT
  /// readers only, while the loop does not run on this source.
  virtual const char* lastError() const noexcept { return ""; }
};

/// The F/T+IMU sensor, drained each cycle. The cycle pairs the robot state with the sample at
/// the robot state's time, interpolated from the history (ftid/daemon/time_pairing.hpp).
class SensorSource {
 public:
  virtual ~SensorSource() = default;
  /// Drains pending data: appends every complete sample received since the previous call to
  /// *history, oldest first (SensorHistory::push; each with its own value flags and validity),
  /// and writes the newest sample, with the driver's health rules applied at now_utime, to
  /// *latest (always written; latest->valid and latest->health_flags tell whether it may be
  /// used, and carry what happened since the previous call: stale, counter gap, error frame,
  /// transport down). now_utime: CLOCK_REALTIME [us], the clock of recv_utime. Each sample
  /// must carry its receipt on the host's monotonic clock too (recv_mono_us; 0 = unknown, and
  /// the cycle treats it as stale): ages and freshness are measured on that clock.
  /// Never blocks, never allocates.
  virtual void drain(std::int64_t now_utime, SensorHistory* history,
                     SensorSampleRecord* latest) noexcept = 0;
  /// Waits until *history holds a sample received at or after t_utime [us, CLOCK_REALTIME],
  /// draining into it as drain() does (what a drain reports about the interval is kept for the
  /// next drain()), or until `timeout` has passed. Returns true if such a sample is there.
  /// Called by the cycle's waitForTick() only (the loop's blocking point); blocks at most
  /// `timeout`, never allocates. Default: no waiting.
  virtual bool waitForSample(std::int64_t t_utime, std::chrono::nanoseconds /*timeout*/,
                             SensorHistory* history) noexcept {
    return !history->empty() && history->newest().recv_utime >= t_utime;
  }
};

/// Sensor-frame kinematics from the joint state.
class MotionModel {
 public:
  virtual ~MotionModel() = default;
  virtual model::SensorMotion computeSensorMotion(const JointVector& q, const JointVector& qd,
                                                  const JointVector& qdd) const noexcept = 0;
};

/// The identified payload model with its parameters: reading -> modelled and contact wrench.
/// One instance is used by the loop thread only; a reload builds a new one off the loop.
class Compensation {
 public:
  virtual ~Compensation() = default;
  /// Base tilt (U, V) [rad] of the parameter set: the cycle fills ctx.g_S with it.
  virtual double tiltU() const noexcept = 0;
  virtual double tiltV() const noexcept = 0;
  /// The parameter set's time origin [s, Unix time] (params::ParameterSet::time_origin_unix_s):
  /// the cycle's model time is host time minus this; NaN (none): since the first valid cycle.
  virtual double timeOriginUnixS() const noexcept { return std::numeric_limits<double>::quiet_NaN(); }
  /// contact = ctx.wrench_S - modelled. Returns false if the result is unusable (non-finite).
  virtual bool compute(const effects::SampleContext& ctx, Wrench* contact,
                       Wrench* modelled) noexcept = 0;
};

/// Where the loop hands its output (the LcmOutbox in production). Must not block.
class CycleSink {
 public:
  virtual ~CycleSink() = default;
  virtual bool tryPush(const CycleRecord& record) noexcept = 0;
};

}  // namespace ftid::daemon
