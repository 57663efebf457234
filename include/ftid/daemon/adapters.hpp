#pragma once
// Production implementations of the daemon seams (ftid/daemon/seams.hpp): thin adapters over
// the UR RTDE client (drivers_ur), the CAN F/T+IMU sensor (drivers_can), RobotKinematics
// (model), the compensator (compensate) with parameters from a parameter file (identify), and
// the LcmOutbox (transport). Constructors do set-up and may throw; the loop-side methods are
// noexcept and allocation-free.
#include <array>
#include <atomic>
#include <chrono>
#include <limits>
#include <memory>
#include <string>

#include "ftid/compensate/compensator.hpp"
#include "ftid/daemon/reloader.hpp"
#include "ftid/daemon/seams.hpp"
#include "ftid/rt/swap_slot.hpp"
#include "ftid/params/parameter_set.hpp"
#include "ftid/drivers/can/ft_imu_sensor.hpp"
#include "ftid/drivers/ur/rtde_client.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/transport/lcm_outbox.hpp"

namespace ftid::daemon {

/// Robot state from RTDE (read-only streaming; nothing is ever sent to the robot).
/// q = actual_q, qd = actual_qd, qdd = target_qdd (the controller's acceleration; if the recipe
/// lacks it, the difference quotient of actual_qd over the controller timestamps).
class RtdeArmSource final : public ArmStateSource {
 public:
  /// Connects and validates the controller, the same checks at start and at every reconnect:
  /// RTDE protocol version 2 accepted, the controller's software version read, frequency_hz not
  /// above what that controller streams (CB3, major < 5: 125 Hz; e-Series: 500 Hz), the output
  /// recipe accepted with the expected types (timestamp, actual_q, actual_qd among them); then
  /// starts streaming. Throws DriverError naming host:port and the failed check.
  RtdeArmSource(const std::string& host, int port, double frequency_hz);
  ~RtdeArmSource() override;
  const char* lastError() const noexcept override { return client_.lastError(); }
  /// The controller's software version, read while connecting.
  const drivers::ur::rtde::ControllerVersion& controllerVersion() const noexcept { return version_; }
  Status waitForState(std::chrono::nanoseconds timeout,
                      RobotStateRecord* out) noexcept override;
  bool robotStopped() const noexcept override { return stopped_; }
  std::uint64_t packetsSkipped() const noexcept override {
    return skipped_.load(std::memory_order_relaxed);
  }
  drivers::ur::RtdeClient& client() noexcept { return client_; }

 private:
  drivers::ur::RtdeClient client_;
  drivers::ur::rtde::ControllerVersion version_{};
  drivers::ur::RtdeStatePackage state_;
  JointVector prev_qd_ = JointVector::Zero();
  double prev_time_ = 0.0;
  bool have_prev_ = false;
  bool stopped_ = false;
  std::atomic<std::uint64_t> skipped_{0};
};

/// Converts a drivers::can::SensorSample (the CAN driver's) into the published record. The
/// health flags are copied unchanged: the driver sets the published bits.
void toSensorRecord(const drivers::can::SensorSample& in, SensorSampleRecord* out) noexcept;

/// One read of both host clocks [us]: CLOCK_MONOTONIC just before (mono_before_us) and just after
/// (mono_after_us) the CLOCK_REALTIME read (real_us), so that the real-time reading lies between.
struct HostClockRead {
  std::int64_t real_us = 0;
  std::int64_t mono_before_us = 0;
  std::int64_t mono_after_us = 0;
  std::int64_t monoUs() const noexcept {
    return mono_before_us + (mono_after_us - mono_before_us) / 2;
  }
  std::int64_t spanUs() const noexcept { return mono_after_us - mono_before_us; }
};

/// A receipt stamped on CLOCK_REALTIME (recv_utime: the kernel's receive timestamp) moved onto
/// CLOCK_MONOTONIC with both clocks read after it (real_now_us, mono_now_us, one instant):
///   monotonicReceiptUs = mono_now_us - (real_now_us - recv_utime),
/// exact when the real-time clock did not step between the receipt and the read. 0 (unknown)
/// if recv_utime <= 0, if real_now_us < recv_utime (the clock stepped back: no age can be read
/// off it) or if the result is not positive.
std::int64_t monotonicReceiptUs(std::int64_t recv_utime, std::int64_t real_now_us,
                                std::int64_t mono_now_us) noexcept;

/// True if CLOCK_REALTIME stepped between two reads of both clocks (prev, then now): their
/// offset real - mono changed by more than both reads' spans plus 0.5 ms. Slewing (NTP,
/// adjtime) changes both clocks' rate alike and never the offset; only a step does. A smaller
/// step moves an age by less than 0.5 ms plus those spans.
bool realtimeStepped(const HostClockRead& prev, const HostClockRead& now) noexcept;

/// The host clocks a CanSensorSource reads right after each receive batch [us]; nullptr: the
/// real CLOCK_REALTIME / CLOCK_MONOTONIC (tests inject fakes). Both noexcept and RT-safe.
struct HostClocks {
  std::int64_t (*realtime_us)() noexcept = nullptr;
  std::int64_t (*monotonic_us)() noexcept = nullptr;
};

/// The CAN sensor, drained each cycle with every complete sample handed to the history.
/// drivers::can::FtImuSensor::tryReadLatest keeps only the newest sample of a drain, so this adapter
/// drains the sensor's transport itself and assembles with its own drivers::can::SampleAssembler (same
/// layout and health options, the same rules): the CanFtImuSensor's own assembler is not used,
/// read health() here instead of sensor->health().
///
/// Reconnect (docs/operations.md, "Link loss and reconnect"): when the transport closes or fails
/// (peer gone, interface error), the loop flags it (transportDown(), any thread) and keeps
/// publishing the cycles with the sensor invalid (transport down, then stale). A non-RT thread
/// opens a new transport and hands it over with offerTransport(); the loop takes it at its next
/// drain (a pointer swap, OwnedSwapSlot: no allocation, no lock) and the old one is freed by
/// collectRetired() off the loop. Samples resume with the next complete one.
class CanSensorSource final : public SensorSource {
 public:
  /// `health` must be the options the sensor was opened with (CanSensorConfig::health). Every
  /// sample gets its receipt on the monotonic clock, recv_mono_us: monotonicReceiptUs(its
  /// recv_utime, the real-time read after the receive batch that completed it, and the monotonic
  /// read just before that, so that a preempted read makes it older, never younger), unless the
  /// real-time clock stepped since the previous read (realtimeStepped; the first read is at
  /// construction); then, until a receive call begun after the step's detection has emptied the
  /// socket, the kernel's stamps say nothing and each receipt is put at the oldest time it can
  /// have: just before the receive call that last emptied the socket (0, unknown, if none did).
  /// A step makes no sample younger than it is by more than realtimeStepped's tolerance
  /// (docs/daemon.md, "Ages on the monotonic clock").
  CanSensorSource(std::unique_ptr<drivers::can::CanFtImuSensor> sensor,
                  const drivers::can::SensorHealthOptions& health, HostClocks clocks = {});
  /// Any thread: true if the transport in use closed or failed and no replacement is waiting.
  bool transportDown() const noexcept {
    return transport_down_.load(std::memory_order_acquire) && !replacement_.hasPending();
  }
  /// Non-RT: offers a freshly opened transport (same endpoint) to the loop.
  void offerTransport(std::unique_ptr<drivers::can::CanTransport> transport) { replacement_.post(std::move(transport)); }
  /// Non-RT: frees a transport the loop has replaced.
  void collectRetired() { replacement_.collectRetired(); }
  /// Any thread: replacement transports taken into use since start.
  std::uint32_t reconnects() const noexcept { return replacement_.version(); }
  void drain(std::int64_t now_utime, SensorHistory* history,
             SensorSampleRecord* latest) noexcept override;
  /// Drains, then ppoll()s the transport's descriptor until such a sample is complete or the
  /// timeout passes (no waiting for a transport without a descriptor, e.g. a candump replay).
  bool waitForSample(std::int64_t t_utime, std::chrono::nanoseconds timeout,
                     SensorHistory* history) noexcept override;
  const drivers::can::SensorHealthCounters& health() const noexcept { return assembler_.health(); }

 private:
  /// Receives pending frames; every complete sample goes to the history (see adapters.cpp).
  void pump(SensorHistory* history) noexcept;
  /// Loop thread: the transport in use (a replacement once one was taken, else the sensor's own).
  drivers::can::CanTransport& bus() noexcept;

  std::unique_ptr<drivers::can::CanFtImuSensor> sensor_;  // owns the first transport
  rt::OwnedSwapSlot<drivers::can::CanTransport> replacement_;  // transports opened after a failure
  std::atomic<bool> transport_down_{false};
  drivers::can::SensorHealthOptions options_;
  drivers::can::SampleAssembler assembler_;
  std::array<drivers::can::ReceivedFrame, 64> batch_{};
  drivers::can::SensorSample sample_;
  SensorSampleRecord record_;
  std::uint32_t interval_flags_ = 0;  ///< gap / error-frame flags pumped since the last drain()
  HostClocks clocks_;
  HostClockRead last_read_;  ///< after the previous receive batch (at construction before any)
  /// Monotonic time just before the last receive call that emptied the socket (0: none yet).
  std::int64_t drained_at_mono_us_ = 0;
  bool step_unresolved_ = false;  ///< a real-time step seen, the socket not emptied since
  /// Both clocks, read together (the real-time read bracketed by two monotonic ones).
  HostClockRead readClocks() const noexcept;
};

/// Sensor-frame kinematics from RobotKinematics (with the sensor mount already set).
class KinematicsMotionModel final : public MotionModel {
 public:
  explicit KinematicsMotionModel(model::RobotKinematics kinematics);
  model::SensorMotion computeSensorMotion(const JointVector& q, const JointVector& qd,
                                          const JointVector& qdd) const noexcept override;

 private:
  model::RobotKinematics kinematics_;
};

/// A compensate::Compensator built from a parameter file (model name, theta, tilt).
class ParameterFileCompensation final : public Compensation {
 public:
  /// Reads and validates the file; throws ConfigError naming the file and key.
  explicit ParameterFileCompensation(const std::string& path);
  /// From a set already read (e.g. with tared offsets); `source` names it in errors. `motion`:
  /// where the motion of S comes from (config sensor.motion_source; kImu subtracts the set's IMU
  /// biases, compensate/compensator.hpp).
  ParameterFileCompensation(const params::ParameterSet& set, const std::string& source,
                            compensate::MotionSource motion = compensate::MotionSource::kKinematics);
  double tiltU() const noexcept override { return tilt_u_; }
  double tiltV() const noexcept override { return tilt_v_; }
  double timeOriginUnixS() const noexcept override { return time_origin_unix_s_; }
  bool compute(const effects::SampleContext& ctx, Wrench* contact,
               Wrench* modelled) noexcept override;
  const std::string& modelName() const noexcept { return model_name_; }

 private:
  std::unique_ptr<compensate::Compensator> compensator_;
  double tilt_u_ = 0.0;
  double tilt_v_ = 0.0;
  double time_origin_unix_s_ = std::numeric_limits<double>::quiet_NaN();
  std::string model_name_;
};

/// Factory for the reloader: path -> ParameterFileCompensation.
CompensationFactory parameterFileFactory();

/// Hands cycles to an LcmOutbox (tryPush: wait-free).
class OutboxSink final : public CycleSink {
 public:
  explicit OutboxSink(transport::LcmOutbox* outbox) : outbox_(outbox) {}
  bool tryPush(const CycleRecord& record) noexcept override {
    return outbox_->tryPush(record);
  }

 private:
  transport::LcmOutbox* outbox_;
};

}  // namespace ftid::daemon
