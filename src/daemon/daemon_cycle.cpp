#include "ftid/common/clock.hpp"
#include "ftid/daemon/daemon_cycle.hpp"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <limits>

#include "ftid/compensate/monitor_log.hpp"
#include "ftid/model/frames.hpp"
#include "ftid/samples/sample_builder.hpp"

namespace ftid::daemon {

std::int64_t realtimeNowUs() noexcept { return realtimeUs(); }
std::int64_t monotonicNowUs() noexcept { return monotonicNs() / 1000; }

namespace {

bool robotUsable(const RobotStateRecord& r) noexcept {
  return r.valid && std::isfinite(r.robot_time) && r.q.allFinite() && r.qd.allFinite() &&
         r.qdd.allFinite();
}

bool sensorFinite(const SensorSampleRecord& s) noexcept {
  if (!s.wrench_S.allFinite()) return false;
  if (s.has_imu && !(s.imu_acc_S.allFinite() && s.imu_w_S.allFinite() && s.imu_alpha_S.allFinite())) {
    return false;
  }
  return !s.has_temp || std::isfinite(s.temp_degC);
}

}  // namespace

void TareAccumulator::start(const TareRequest& request) noexcept {
  request_ = request;
  if (request_.cycles == 0) request_.cycles = 1;
  active_ = true;
  n_ = 0;
  version_ = 0;
  max_qd_ = 0.0;
  max_qdd_ = 0.0;
  sum_.setZero();
}

bool TareAccumulator::add(const CycleRecord& rec, TareResult* result) noexcept {
  if (!active_) return false;
  const auto version = static_cast<std::uint32_t>(rec.param_version);
  if (n_ == 0) version_ = version;
  const double qd = rec.robot.qd.allFinite() ? rec.robot.qd.cwiseAbs().maxCoeff()
                                             : std::numeric_limits<double>::infinity();
  const double qdd = rec.robot.qdd.allFinite() ? rec.robot.qdd.cwiseAbs().maxCoeff()
                                               : std::numeric_limits<double>::infinity();
  max_qd_ = std::max(max_qd_, qd);
  max_qdd_ = std::max(max_qdd_, qdd);
  TareOutcome outcome = TareOutcome::kOk;
  bool done = false;
  if (!(qd <= request_.max_qd_rad_s) || !(qdd <= request_.max_qdd_rad_s2)) {
    outcome = TareOutcome::kMoving;
    done = true;
  } else if (!rec.wrench_valid || !rec.contact_S.allFinite()) {
    outcome = TareOutcome::kInvalid;
    done = true;
  } else if (version != version_) {
    outcome = TareOutcome::kParametersChanged;
    done = true;
  } else {
    sum_ += rec.contact_S;
    ++n_;
    done = n_ >= request_.cycles;
  }
  if (!done) return false;
  result->id = request_.id;
  result->outcome = outcome;
  result->cycles = n_;
  result->param_version = version_;
  result->max_qd = max_qd_;
  result->max_qdd = max_qdd_;
  result->mean_contact_S = n_ > 0 ? Wrench(sum_ / static_cast<double>(n_)) : Wrench(Wrench::Zero());
  active_ = false;
  return true;
}

DaemonCycle::DaemonCycle(ArmStateSource* arm, SensorSource* sensor, const MotionModel* motion,
                         rt::OwnedSwapSlot<Compensation>* params, CycleSink* sink, CycleOptions options)
    : arm_(arm),
      sensor_(sensor),
      motion_(motion),
      params_(params),
      sink_(sink),
      options_(options),
      clock_map_(options.clock_window_s),
      clock_check_(options.clock_check) {
  if (options_.mono_now_us == nullptr) {
    options_.mono_now_us = options_.now_us == &realtimeNowUs ? &monotonicNowUs : options_.now_us;
  }
}

Status DaemonCycle::waitForTick(std::chrono::nanoseconds timeout) noexcept {
  const Status s = arm_->waitForState(timeout, &robot_);
  if (s == Status::kOk) awaitBracketingSample();
  return s;
}

// The robot state's time on the host clock is normally about when its packet arrived, so the
// sensor sample after it (needed to interpolate) is usually still in flight: wait for it here,
// at the loop's blocking point (not counted as compute time), bounded by max_sensor_wait_us and
// half a robot period, and not at all while the sensor is silent (the cycle is stale anyway).
void DaemonCycle::awaitBracketingSample() noexcept {
  const double robot_time = robot_.robot_time;
  const double period_s = robot_time - prev_wait_robot_time_;
  prev_wait_robot_time_ = robot_time;
  if (options_.max_sensor_wait_us <= 0 || !std::isfinite(robot_time) || robot_.recv_utime <= 0) {
    return;
  }
  const std::int64_t t_pair = clock_map_.update(robot_time, robot_.recv_utime);  // step() repeats it
  if (sensor_->waitForSample(t_pair, std::chrono::nanoseconds(0), &history_)) return;  // there
  if (history_.empty() || history_.newest().recv_mono_us <= 0 ||
      options_.mono_now_us() - history_.newest().recv_mono_us > options_.stale_timeout_us) {
    return;  // no sensor data yet, or the sensor is silent (on the monotonic clock)
  }
  std::int64_t wait_us = options_.max_sensor_wait_us;
  if (period_s > 0.0 && period_s < 1.0) {
    wait_us = std::min(wait_us, static_cast<std::int64_t>(period_s * 0.5e6));
  }
  counters_.sensor_waits.fetch_add(1, std::memory_order_relaxed);
  if (!sensor_->waitForSample(t_pair, std::chrono::microseconds(wait_us), &history_)) {
    counters_.sensor_wait_timeouts.fetch_add(1, std::memory_order_relaxed);
  }
}

CycleAction DaemonCycle::onTick() noexcept {
  step(robot_, nullptr);
  if (loop_stats_ != nullptr && ++since_stats_ >= stats_every_) {
    stats_box_->tryPush(*loop_stats_);
    since_stats_ = 0;
  }
  return CycleAction::kContinue;
}

CycleAction DaemonCycle::onMissed(std::uint32_t /*consecutive_missed*/) noexcept {
  counters_.missed.fetch_add(1, std::memory_order_relaxed);
  faults_.raise(kFaultRobotTimeout);
  return CycleAction::kContinue;
}

void DaemonCycle::step(const RobotStateRecord& robot,
                       CycleRecord* out) noexcept {
  const std::int64_t now = options_.now_us();
  // Ages and the controller clock's check are on the host's monotonic clock, read once here: a
  // step of the real-time clock (NTP, an operator) never makes an old sample fresh (issue 26).
  const std::int64_t mono_now = options_.mono_now_us();
  Compensation* comp = acquireParameters();
  beginRecord(robot, now);
  const bool robot_ok = checkRobotState(robot);
  const bool clock_sane = checkControllerClock(robot, robot_ok, mono_now);
  pairSensorSample(robot, now);
  const bool sample_fresh = checkSensorSample(mono_now);
  compensate(robot, comp, robot_ok && clock_sane && record_.sensor.valid && sample_fresh);
  applyOutputStage();
  countAndTare();
  publish(now, out);
}

// Takes new parameters into use if a reload posted them; returns the set in use (nullptr: none).
Compensation* DaemonCycle::acquireParameters() noexcept {
  if (params_->tryAcquire() != nullptr) {
    counters_.param_swaps.fetch_add(1, std::memory_order_relaxed);
  }
  return params_->current();
}

// Starts this cycle's record: times, cycle number, the robot state as received, no faults yet.
void DaemonCycle::beginRecord(const RobotStateRecord& robot, std::int64_t now) noexcept {
  CycleRecord& rec = record_;
  rec.utime = now;
  rec.cycle = cycle_number_++;
  rec.robot = robot;
  rec.fault_bits = 0;
  rec.param_version = static_cast<std::int32_t>(params_->version());
}

// Robot state: usable (valid, finite) or flagged kFaultRobotStopped, as is an arm that reports
// itself stopped. Returns whether the state is usable.
bool DaemonCycle::checkRobotState(const RobotStateRecord& robot) noexcept {
  CycleRecord& rec = record_;
  const bool robot_ok = robotUsable(robot);
  rec.robot.valid = robot_ok;
  if (!robot_ok) {
    rec.fault_bits |= kFaultRobotStopped;
    counters_.invalid_robot.fetch_add(1, std::memory_order_relaxed);
  }
  if (arm_ != nullptr && arm_->robotStopped()) rec.fault_bits |= kFaultRobotStopped;
  return robot_ok;
}

// The controller's clock against the host's monotonic clock (issue 26): stopped, jumping or
// running at a wrong rate, the pairing would pick samples of the wrong time. Returns its sanity.
bool DaemonCycle::checkControllerClock(const RobotStateRecord& robot, bool robot_ok,
                                       std::int64_t mono_now) noexcept {
  CycleRecord& rec = record_;
  const bool clock_sane = clock_check_.update(robot.robot_time, mono_now);
  counters_.robot_clock_faults.store(clock_check_.faults(), std::memory_order_relaxed);
  if (robot_ok && !clock_sane) {
    // Its time cannot be trusted, so neither can any pairing with it: the state is unusable
    // (not compensated, and left out of identification logs).
    rec.robot.valid = false;
    rec.fault_bits |= kFaultRobotClock;
    counters_.robot_clock_invalid.fetch_add(1, std::memory_order_relaxed);
  }
  return clock_sane;
}

// Sensor: every new sample into the history (latest_ is the newest with the driver's flags),
// then rec.sensor = the sample at the robot state's time on the host clock (interpolated), else
// the newest.
void DaemonCycle::pairSensorSample(const RobotStateRecord& robot, std::int64_t now) noexcept {
  CycleRecord& rec = record_;
  sensor_->drain(now, &history_, &latest_);
  SensorPairing pairing = SensorPairing::kNone;
  std::int64_t reach_us = 0;
  last_pair_time_us_ = 0;
  if (std::isfinite(robot.robot_time) && robot.recv_utime > 0) {
    last_pair_time_us_ = clock_map_.update(robot.robot_time, robot.recv_utime);
    pairing = history_.sampleAt(last_pair_time_us_, &rec.sensor, &reach_us);
  }
  last_pairing_ = pairing;
  if (pairing == SensorPairing::kNone) {
    rec.sensor = latest_;
    counters_.sensor_unpaired.fetch_add(1, std::memory_order_relaxed);
  } else {
    // The newest sample's flags and validity still count (stale, transport down, counter gap,
    // error frames since the last cycle, an invalid newest value): never less strict than before.
    rec.sensor.health_flags |= latest_.health_flags;
    rec.sensor.valid = rec.sensor.valid && latest_.valid;
    if (reach_us > options_.stale_timeout_us) rec.sensor.health_flags |= kHealthStale;
    if (pairing == SensorPairing::kInterpolated) {
      counters_.sensor_interpolated.fetch_add(1, std::memory_order_relaxed);
    } else {
      counters_.sensor_one_sided.fetch_add(1, std::memory_order_relaxed);
    }
  }
}

// Flags the paired sample stale or invalid (then rec.sensor.valid is false and a sensor fault is
// raised). Returns whether it is fresh: age on the monotonic clock within stale_timeout_us.
bool DaemonCycle::checkSensorSample(std::int64_t mono_now) noexcept {
  CycleRecord& rec = record_;
  // Stale: no sample ever (or its receipt unknown), or the newest one older than the timeout at
  // the start of the cycle on the monotonic clock (the rule before pairing); the pairing itself
  // (reach_us in pairSensorSample) adds the samples' distance from the robot state's time.
  // A sample completed by the drain, after mono_now was read, is of age 0.
  rec.sensor_age_us = -1;
  if (rec.sensor.recv_mono_us > 0) {
    rec.sensor_age_us = std::max<std::int64_t>(0, mono_now - rec.sensor.recv_mono_us);
  }
  if (rec.sensor.recv_mono_us <= 0 || latest_.recv_mono_us <= 0 ||
      mono_now - latest_.recv_mono_us > options_.stale_timeout_us) {
    rec.sensor.health_flags |= kHealthStale;
  }
  // Freshness of the output (issue 26): the sample used must itself be younger than the timeout
  // on the host's monotonic clock, whatever the controller's clock says, or the published
  // contact wrench is not the current one. The sample stays valid as data (a backlog's pairing
  // is time-consistent and may be recorded for identification): only the compensated wrench of
  // this cycle is refused, as stale.
  const bool sample_fresh = rec.sensor_age_us >= 0 && rec.sensor_age_us <= options_.stale_timeout_us;
  if (!sensorFinite(rec.sensor)) rec.sensor.health_flags |= kHealthNonFinite;
  if ((rec.sensor.health_flags & (kHealthStale | kHealthNonFinite)) != 0) {
    rec.sensor.valid = false;
  }
  if (!rec.sensor.valid) {
    if ((rec.sensor.health_flags & kHealthStale) != 0) {
      rec.fault_bits |= kFaultSensorStale;
      counters_.stale_sensor.fetch_add(1, std::memory_order_relaxed);
    } else {
      rec.fault_bits |= kFaultSensorInvalid;
      counters_.invalid_sensor.fetch_add(1, std::memory_order_relaxed);
    }
  } else if (!sample_fresh) {
    rec.fault_bits |= kFaultSensorStale;
    counters_.stale_sensor.fetch_add(1, std::memory_order_relaxed);
  }
  return sample_fresh;
}

// Compensation, only from valid inputs: rec.contact_S and rec.modelled_S, else zero and
// wrench_valid = false.
void DaemonCycle::compensate(const RobotStateRecord& robot, Compensation* comp,
                             bool inputs_valid) noexcept {
  CycleRecord& rec = record_;
  rec.wrench_valid = false;
  rec.modelled_S.setZero();
  rec.contact_S.setZero();
  if (comp == nullptr) {
    counters_.no_parameters.fetch_add(1, std::memory_order_relaxed);
  } else if (inputs_valid) {
    const double t_s = sampleTimeS(robot);
    const double t_model_s = modelTimeS(robot, *comp);
    makeContext(robot, *comp, t_s, t_model_s);
    computeContact(comp);
  }
}

// Sample time t [s]: the robot clock since the session's anchor, re-anchored when the controller
// clock goes back (a controller reboot; a repeated time keeps the anchor) so it never runs
// negative (the compensator restarts its delay line when t does not advance).
double DaemonCycle::sampleTimeS(const RobotStateRecord& robot) noexcept {
  if (!have_first_time_ || !(robot.robot_time >= last_robot_time_)) {
    first_robot_time_ = robot.robot_time;
    have_first_time_ = true;
  }
  last_robot_time_ = robot.robot_time;
  return robot.robot_time - first_robot_time_;
}

// The model's time [s] (docs/conventions.md, "Time and logs"): the host's UTC receive time of the
// state minus the parameter set's time origin, else minus the first valid cycle's (kept over
// reconnects and controller reboots: the host clock does not reset with the controller).
double DaemonCycle::modelTimeS(const RobotStateRecord& robot, const Compensation& comp) noexcept {
  const double host_time_s = hostTimeSeconds(robot.recv_utime);
  if (!have_first_host_time_) {
    first_host_time_s_ = host_time_s;
    have_first_host_time_ = true;
  }
  const double origin_s = comp.timeOriginUnixS();
  return host_time_s - (std::isfinite(origin_s) ? origin_s : first_host_time_s_);
}

// ctx_ from the joint state (sensor motion by kinematics), the paired sensor reading and gravity
// in the base frame for the parameters' tilt.
void DaemonCycle::makeContext(const RobotStateRecord& robot, const Compensation& comp, double t_s,
                              double t_model_s) noexcept {
  const CycleRecord& rec = record_;
  const model::SensorMotion m = motion_->computeSensorMotion(robot.q, robot.qd, robot.qdd);
  samples::SensorReading reading;
  reading.wrench_S = rec.sensor.wrench_S;
  reading.has_imu = rec.sensor.has_imu;
  reading.imu_acc_S = rec.sensor.imu_acc_S;
  reading.imu_w_S = rec.sensor.imu_w_S;
  reading.imu_alpha_S = rec.sensor.imu_alpha_S;
  reading.has_temp = rec.sensor.has_temp;
  reading.temp_degC = rec.sensor.temp_degC;
  samples::makeSampleContext(t_s, t_model_s, robot.q, robot.qd, m, reading,
                             model::gravityInBase(comp.tiltU(), comp.tiltV()), &ctx_);
}

// The compensation of ctx_: contact_S = measured - modelled_S, both finite, into the record (and
// to the payload monitor); a failure counts as a model failure and an invalid sensor.
void DaemonCycle::computeContact(Compensation* comp) noexcept {
  CycleRecord& rec = record_;
  Wrench contact;
  Wrench modelled;
  const bool ok = comp->compute(ctx_, &contact, &modelled) && contact.allFinite() &&
                  modelled.allFinite();
  if (ok) {
    rec.contact_S = contact;
    rec.modelled_S = modelled;
    rec.wrench_valid = true;
    if (monitor_link_ != nullptr) {
      monitor_link_->handOver(MonitorInput{compensate::monitorSample(ctx_, contact), rec.param_version});
    }
  } else {
    counters_.model_failures.fetch_add(1, std::memory_order_relaxed);
    rec.fault_bits |= kFaultSensorInvalid;
  }
}

// Output stage: the contact wrench in the configured frame, filtered (docs/daemon.md); without
// one, the contact wrench in S.
void DaemonCycle::applyOutputStage() noexcept {
  CycleRecord& rec = record_;
  if (output_stage_ != nullptr) {
    rec.output = output_stage_->process(rec.contact_S, ctx_.R_BS, rec.wrench_valid);
    rec.output_frame = static_cast<std::int8_t>(output_stage_->frame());
  } else {
    rec.output = rec.contact_S;
    rec.output_frame = 0;
  }
}

// Counts the cycle valid or invalid and feeds the tare window (docs/daemon.md, "Tare"): a new
// request starts it; the result goes back off the loop.
void DaemonCycle::countAndTare() noexcept {
  const CycleRecord& rec = record_;
  if (rec.wrench_valid) {
    counters_.valid.fetch_add(1, std::memory_order_relaxed);
  } else {
    counters_.invalid.fetch_add(1, std::memory_order_relaxed);
  }
  if (tare_requests_ != nullptr) {
    if (tare_requests_->tryPop(&tare_request_)) tare_.start(tare_request_);
    if (tare_.add(rec, &tare_result_)) tare_results_->tryPush(tare_result_);
  }
}

// Hands the record to the sink (a refusal is kFaultPublishDropped), raises its faults, and
// updates the heartbeat counters; *out gets a copy.
void DaemonCycle::publish(std::int64_t now, CycleRecord* out) noexcept {
  CycleRecord& rec = record_;
  // The payload monitor's flags ride on every wrench; they are no faults (docs/daemon.md).
  if (monitor_link_ != nullptr) rec.fault_bits |= monitor_link_->flags();
  if (sink_ != nullptr && !sink_->tryPush(rec)) {
    counters_.sink_dropped.fetch_add(1, std::memory_order_relaxed);
    rec.fault_bits |= kFaultPublishDropped;
  }
  faults_.raise(rec.fault_bits & ~kWrenchFlagMask);
  counters_.last_utime.store(now, std::memory_order_relaxed);
  counters_.cycles.fetch_add(1, std::memory_order_release);
  if (out != nullptr) *out = rec;
}

}  // namespace ftid::daemon
