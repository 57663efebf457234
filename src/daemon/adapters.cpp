#include "ftid/common/clock.hpp"
#include "ftid/daemon/adapters.hpp"
#include "ftid/daemon/reloader.hpp"

#include <poll.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <ctime>

#include "ftid/common/error.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/effects/signal_source.hpp"
#include "ftid/params/parameter_set.hpp"

namespace ftid::daemon {

namespace ur = drivers::ur;

// ---------------------------------------------------------------------------------------------
RtdeArmSource::RtdeArmSource(const std::string& host, int port, double frequency_hz) {
  const std::string where = "RTDE " + host + ":" + std::to_string(port);
  client_.connect(host, static_cast<std::uint16_t>(port));
  if (!client_.negotiateProtocolVersion(ur::rtde::kProtocolVersion2)) {
    throw DriverError(where + ": the controller refused RTDE protocol version 2");
  }
  version_ = client_.controllerVersion();
  const double max_hz = version_.major >= 5 ? 500.0 : 125.0;
  if (frequency_hz > max_hz) {
    throw DriverError(where + ": controller " + version_.toString() + " streams at most " +
                      std::to_string(static_cast<int>(max_hz)) + " Hz, robot.rtde_frequency_hz is " +
                      std::to_string(frequency_hz));
  }
  client_.setupOutputs(frequency_hz, ur::RtdeClient::defaultOutputNames());  // recipe and types
  client_.start();
}

RtdeArmSource::~RtdeArmSource() { client_.disconnect(); }

Status RtdeArmSource::waitForState(std::chrono::nanoseconds timeout,
                                   RobotStateRecord* out) noexcept {
  const Status s = client_.tryReceiveState(timeout, &state_);
  if (s != Status::kOk) return s;
  if (state_.packages_skipped > 0) {
    skipped_.fetch_add(state_.packages_skipped, std::memory_order_relaxed);
  }
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  out->recv_utime = static_cast<std::int64_t>(ts.tv_sec) * 1'000'000 + ts.tv_nsec / 1000;
  out->robot_time = state_.timestamp;
  for (int j = 0; j < 6; ++j) {
    const auto k = static_cast<std::size_t>(j);
    out->q(j) = state_.actual_q[k];
    out->qd(j) = state_.actual_qd[k];
  }
  if ((state_.present & ur::kFieldTargetQdd) != 0) {
    for (int j = 0; j < 6; ++j) out->qdd(j) = state_.target_qdd[static_cast<std::size_t>(j)];
  } else if (have_prev_ && state_.timestamp > prev_time_) {
    out->qdd = (out->qd - prev_qd_) / (state_.timestamp - prev_time_);
  } else {
    out->qdd.setZero();
  }
  prev_qd_ = out->qd;
  prev_time_ = state_.timestamp;
  have_prev_ = true;
  const std::uint32_t present = state_.present;
  out->valid = (present & ur::kFieldActualQ) != 0 && (present & ur::kFieldActualQd) != 0 &&
               (present & ur::kFieldTimestamp) != 0;
  stopped_ = (state_.safety_status_bits &
              (ur::rtde::kSafetyStatusProtectiveStopped | ur::rtde::kSafetyStatusSafeguardStopped |
               ur::rtde::kSafetyStatusSystemEmergencyStopped |
               ur::rtde::kSafetyStatusRobotEmergencyStopped |
               ur::rtde::kSafetyStatusEmergencyStopped | ur::rtde::kSafetyStatusFault |
               ur::rtde::kSafetyStatusViolation)) != 0;
  return Status::kOk;
}

// ---------------------------------------------------------------------------------------------
void toSensorRecord(const drivers::can::SensorSample& in, SensorSampleRecord* out) noexcept {
  out->recv_utime = in.rx_time_ns / 1000;
  out->counter = static_cast<std::int32_t>(in.counter);
  out->wrench_S = in.wrench_S;
  out->has_imu = in.has_imu;
  if (in.has_imu) {
    out->imu_acc_S = in.acc_S;
    out->imu_w_S = in.w_S;
    out->imu_alpha_S = in.alpha_S;
  } else {
    out->imu_acc_S.setZero();
    out->imu_w_S.setZero();
    out->imu_alpha_S.setZero();
  }
  out->has_temp = in.has_temperature;
  out->temp_degC = in.has_temperature ? in.temp_degC : 0.0;
  out->status_word = static_cast<std::int32_t>(in.status_word);
  out->health_flags = in.health_flags;  // the driver sets the published bits (sensor_health.hpp)
  out->valid = in.valid;
}

std::int64_t monotonicReceiptUs(std::int64_t recv_utime, std::int64_t real_now_us,
                                std::int64_t mono_now_us) noexcept {
  if (recv_utime <= 0 || real_now_us < recv_utime) return 0;
  const std::int64_t receipt = mono_now_us - (real_now_us - recv_utime);
  return receipt > 0 ? receipt : 0;
}

bool realtimeStepped(const HostClockRead& prev, const HostClockRead& now) noexcept {
  // NTP's and adjtime's slewing changes both clocks' rate alike: only a step moves the offset.
  const std::int64_t change_us = (now.real_us - now.monoUs()) - (prev.real_us - prev.monoUs());
  const std::int64_t tolerance_us = 500 + prev.spanUs() + now.spanUs();
  return change_us > tolerance_us || change_us < -tolerance_us;
}

CanSensorSource::CanSensorSource(std::unique_ptr<drivers::can::CanFtImuSensor> sensor,
                                 const drivers::can::SensorHealthOptions& health,
                                 HostClocks clocks)
    : sensor_(std::move(sensor)), options_(health), assembler_(sensor_->layout(), health),
      clocks_(clocks) {
  if (clocks_.realtime_us == nullptr) clocks_.realtime_us = &realtimeUs;
  if (clocks_.monotonic_us == nullptr) clocks_.monotonic_us = &monotonicUs;
  last_read_ = readClocks();  // a step before the first drain is seen too (frames queue from here)
}

HostClockRead CanSensorSource::readClocks() const noexcept {
  HostClockRead r;
  r.mono_before_us = clocks_.monotonic_us();
  r.real_us = clocks_.realtime_us();
  r.mono_after_us = clocks_.monotonic_us();
  return r;
}

namespace {
// The events of one per-sample read that belong to the interval since the previous cycle: lost
// samples (a counter gap) and error frames. A repeated counter also sets kHealthCounterGap, but it
// is that sample's own flag, not an event of the interval (the read right after each completed
// sample consumes the driver's pending gap, so a repeat never carries one).
std::uint32_t intervalEvents(std::uint32_t flags) noexcept {
  std::uint32_t events = flags & kHealthErrorFrame;
  if ((flags & kHealthCounterGap) != 0 && (flags & kHealthCounterRepeat) == 0) {
    events |= kHealthCounterGap;
  }
  return events;
}
}  // namespace

// The drain loop of CanFtImuSensor::tryReadLatest, except that every complete sample is read
// (at its own receive time, so that it is never stale there) and appended to the history. The
// counter-gap and error-frame flags such a read consumes belong to the interval since the
// previous cycle: they are collected and reported with the newest sample by drain(), as one read
// per cycle reports them.
drivers::can::CanTransport& CanSensorSource::bus() noexcept {
  if (replacement_.tryAcquire() != nullptr) transport_down_.store(false, std::memory_order_release);
  drivers::can::CanTransport* r = replacement_.current();
  return r != nullptr ? *r : sensor_->transport();
}

void CanSensorSource::pump(SensorHistory* history) noexcept {
  drivers::can::CanTransport& bus = this->bus();
  int total = 0;
  while (total < drivers::can::CanFtImuSensor::kMaxFramesPerRead) {
    drivers::can::IoResult status = drivers::can::IoResult::kOk;
    const std::int64_t mono_before_receive_us = clocks_.monotonic_us();
    const int n = bus.tryReceiveBatch(batch_.data(), static_cast<int>(batch_.size()), status);
    // Both host clocks, read together right after the receipt (monotonicReceiptUs). If the
    // real-time clock stepped since the previous read, the kernel's stamps of the frames still
    // queued say nothing until the socket has been emptied: they get the oldest possible receipt.
    const HostClockRead read = readClocks();
    const bool stepped = realtimeStepped(last_read_, read);
    if (stepped) step_unresolved_ = true;
    last_read_ = read;
    for (int i = 0; i < n; ++i) {
      if (!assembler_.feed(batch_[static_cast<std::size_t>(i)])) continue;
      assembler_.readLatest(sample_, assembler_.latest().rx_time_ns);
      interval_flags_ |= intervalEvents(sample_.health_flags);
      toSensorRecord(sample_, &record_);
      // mono_before_us: no later than the real-time read, so a receipt is never made younger.
      record_.recv_mono_us = step_unresolved_ ? drained_at_mono_us_
                                              : monotonicReceiptUs(record_.recv_utime, read.real_us,
                                                                   read.mono_before_us);
      history->push(record_);
    }
    total += n;
    if (status == drivers::can::IoResult::kClosed || status == drivers::can::IoResult::kError) {
      assembler_.noteTransportProblem();
      transport_down_.store(true, std::memory_order_release);
      break;
    }
    if (n < static_cast<int>(batch_.size())) {  // emptied: later frames arrive after the call
      drained_at_mono_us_ = mono_before_receive_us;
      // Resolved once a call that began after the step's read has emptied the socket (the step
      // may lie after this call, before the read: frames of that moment are still queued).
      if (!stepped) step_unresolved_ = false;
      break;
    }
  }
}

void CanSensorSource::drain(std::int64_t now_utime, SensorHistory* history,
                            SensorSampleRecord* latest) noexcept {
  pump(history);
  // The driver's own staleness test, on the monotonic age of the newest sample (the last one
  // pumped) when it is known: a step of the real-time clock does not flag a fresh sample.
  std::int64_t now_ns = now_utime * 1000;
  if (record_.recv_mono_us > 0) {
    now_ns = (record_.recv_utime + (clocks_.monotonic_us() - record_.recv_mono_us)) * 1000;
  }
  assembler_.readLatest(sample_, now_ns);
  sample_.health_flags |= interval_flags_;
  if (((interval_flags_ & kHealthCounterGap) != 0 && options_.counter_gap_invalidates) ||
      ((interval_flags_ & kHealthErrorFrame) != 0 && options_.error_frame_invalidates)) {
    sample_.valid = false;
  }
  interval_flags_ = 0;
  toSensorRecord(sample_, latest);
  // The newest sample is the last one pumped (the assembler completes samples in order).
  latest->recv_mono_us = latest->recv_utime == record_.recv_utime ? record_.recv_mono_us : 0;
}

bool CanSensorSource::waitForSample(std::int64_t t_utime, std::chrono::nanoseconds timeout,
                                    SensorHistory* history) noexcept {
  auto have = [&] { return !history->empty() && history->newest().recv_utime >= t_utime; };
  const std::int64_t deadline = monotonicNs() + timeout.count();
  const int fd = bus().fd();
  for (;;) {
    pump(history);
    if (have()) return true;
    const std::int64_t left = deadline - monotonicNs();
    if (left <= 0 || fd < 0) return false;
    pollfd p{fd, POLLIN, 0};
    const timespec wait{static_cast<time_t>(left / 1'000'000'000), static_cast<long>(left % 1'000'000'000)};
    if (ppoll(&p, 1, &wait, nullptr) < 0 && errno != EINTR) return false;
  }
}

// ---------------------------------------------------------------------------------------------
KinematicsMotionModel::KinematicsMotionModel(model::RobotKinematics kinematics)
    : kinematics_(std::move(kinematics)) {}

model::SensorMotion KinematicsMotionModel::computeSensorMotion(const JointVector& q,
                                                               const JointVector& qd,
                                                               const JointVector& qdd) const noexcept {
  return kinematics_.computeSensorMotion(q, qd, qdd);
}

// ---------------------------------------------------------------------------------------------
ParameterFileCompensation::ParameterFileCompensation(const std::string& path)
    : ParameterFileCompensation(params::readParameterFile(path), path) {}

ParameterFileCompensation::ParameterFileCompensation(const params::ParameterSet& set, const std::string& path,
                                                     compensate::MotionSource motion) {
  const effects::Model model = effects::Model::fromName(set.model);
  const Eigen::VectorXd theta = params::thetaFor(model, set, path);
  if (const auto columns = effects::extraColumnsRead(model); !columns.empty()) {
    std::string list;
    for (const auto& c : columns) list += (list.empty() ? "'" : ", '") + c + "'";
    throw ConfigError(path + ": model '" + set.model + "' reads the log column(s) " + list +
                      ", which ftidd does not receive at run time; compensate such a model offline with "
                      "`ftid compensate`, or identify one without it for ftidd (docs/effects.md)");
  }
  if (!std::isfinite(set.tilt_u_rad) || !std::isfinite(set.tilt_v_rad)) {
    throw ConfigError(path + ": key 'tilt': tilt angles must be finite");
  }
  tilt_u_ = set.tilt_u_rad;
  tilt_v_ = set.tilt_v_rad;
  time_origin_unix_s_ = set.time_origin_unix_s;
  model_name_ = model.name();
  compensate::CompensatorOptions options;
  options.motion = motion;
  const Vec6 bias = params::imuBiasesOf(set);
  options.imu_bias.acc_mps2 = bias.head<3>();
  options.imu_bias.gyro_radps = bias.tail<3>();
  compensator_ = std::make_unique<compensate::Compensator>(model, theta, params::nonlinearFor(model, set, path),
                                                           options);
}

bool ParameterFileCompensation::compute(const effects::SampleContext& ctx, Wrench* contact,
                                        Wrench* modelled) noexcept {
  return compensator_->compute(ctx, contact, modelled) == Status::kOk;
}

CompensationFactory parameterFileFactory() {
  return [](const std::string& path) -> std::unique_ptr<Compensation> {
    // Never block on a FIFO, a device or a pipe named as the parameter file (issue 14).
    if (const std::string problem = regularFileProblem(path); !problem.empty()) throw ConfigError(problem);
    return std::make_unique<ParameterFileCompensation>(path);
  };
}

}  // namespace ftid::daemon
