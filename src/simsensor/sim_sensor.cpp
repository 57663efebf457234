// ftid sim-sensor: robot state over RTDE -> cell physics -> CAN frames on the stand-in socket.
#include "ftid/common/clock.hpp"
#include "ftid/simsensor/sim_sensor.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <fstream>
#include <sstream>
#include <thread>

#include "ftid/common/error.hpp"
#include "ftid/drivers/can/candump.hpp"
#include "ftid/drivers/can/seqpacket.hpp"
#include "ftid/drivers/can/socketcan.hpp"
#include "ftid/drivers/ur/rtde_client.hpp"
#include "ftid/rt/cyclic_executor.hpp"

namespace ftid::simsensor {

namespace {

constexpr const char* kFaultNames[] = {"silent",        "counter_gap",   "out_of_range",
                                       "error_frame",   "bus_off",       "stuck_counter",
                                       "status_fault"};

/// A host stall of up to this many sample periods is caught up (late samples); a longer one
/// re-anchors the sample clock and shows as a counter gap.
constexpr std::uint32_t kCatchUpPeriods = 50;

JointVector toJoint(const drivers::ur::Joint6& a) {
  JointVector v;
  for (int i = 0; i < 6; ++i) v[i] = a[static_cast<std::size_t>(i)];
  return v;
}

using Progress = std::function<void(const std::string&)>;

/// Passes s to the caller's progress callback, if there is one.
void say(const Progress& progress, const std::string& s) {
  if (progress) progress(s);
}

}  // namespace

SensorFault parseSensorFault(const std::string& name) {
  for (std::size_t i = 0; i < std::size(kFaultNames); ++i) {
    if (name == kFaultNames[i]) return static_cast<SensorFault>(i);
  }
  throw ConfigError("unknown sensor fault '" + name +
                    "' (silent, counter_gap, out_of_range, error_frame, bus_off, stuck_counter, "
                    "status_fault)");
}

const char* sensorFaultName(SensorFault fault) noexcept {
  return kFaultNames[static_cast<std::size_t>(fault)];
}

// ----------------------------------------------------------------------------------- history

void RobotHistory::add(const Tick& tick) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (count_ > 0) {
    const Tick& newest = ring_[(head_ + kCapacity - 1) % kCapacity];
    if (tick.t < newest.t - 1.0) {  // controller restarted: its clock began again
      count_ = 0;
      head_ = 0;
      ++generation_;
    } else if (!(tick.t > newest.t)) {
      return;
    }
  }
  if (count_ > 0) {
    const Tick& newest = ring_[(head_ + kCapacity - 1) % kCapacity];
    const double dt = tick.t - newest.t;
    // Track the nominal period with a slow filter that ignores gaps (dropped packages).
    if (dt < 2.5 * period_ || count_ < 3) period_ = count_ < 3 ? dt : 0.9 * period_ + 0.1 * dt;
  }
  ring_[head_] = tick;
  head_ = (head_ + 1) % kCapacity;
  count_ = std::min(count_ + 1, kCapacity);
}

std::uint64_t RobotHistory::generation() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return generation_;
}

bool RobotHistory::empty() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return count_ == 0;
}

std::size_t RobotHistory::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return count_;
}

double RobotHistory::newestTime() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return count_ == 0 ? 0.0 : ring_[(head_ + kCapacity - 1) % kCapacity].t;
}

double RobotHistory::oldestTime() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return count_ == 0 ? 0.0 : ring_[(head_ + kCapacity - count_) % kCapacity].t;
}

double RobotHistory::period() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return period_;
}

bool RobotHistory::stateAt(double t, Tick& out) const {
  std::lock_guard<std::mutex> lock(mutex_);
  if (count_ == 0) return false;
  const auto at = [&](std::size_t i) -> const Tick& {  // i = 0 oldest .. count_-1 newest
    return ring_[(head_ + kCapacity - count_ + i) % kCapacity];
  };
  const Tick& newest = at(count_ - 1);
  if (t >= newest.t) {
    const double dt = t - newest.t;
    out = newest;
    out.t = t;
    if (dt <= 3.0 * period_) {  // constant-acceleration extrapolation
      out.q = newest.q + newest.qd * dt + 0.5 * newest.qdd * dt * dt;
      out.qd = newest.qd + newest.qdd * dt;
    } else {  // the stream stopped: hold the robot still where it was last seen
      out.qd.setZero();
      out.qdd.setZero();
    }
    return true;
  }
  const Tick& oldest = at(0);
  if (t <= oldest.t) {
    out = oldest;
    out.t = t;
    return true;
  }
  // Binary search for the bracketing pair a.t <= t < b.t.
  std::size_t lo = 0;
  std::size_t hi = count_ - 1;
  while (hi - lo > 1) {
    const std::size_t mid = (lo + hi) / 2;
    if (at(mid).t <= t) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  const Tick& a = at(lo);
  const Tick& b = at(hi);
  const double h = b.t - a.t;
  const double s = (t - a.t) / h;
  // Cubic Hermite basis and derivatives (with respect to t).
  const double h00 = 2 * s * s * s - 3 * s * s + 1;
  const double h10 = s * s * s - 2 * s * s + s;
  const double h01 = -2 * s * s * s + 3 * s * s;
  const double h11 = s * s * s - s * s;
  const double d00 = (6 * s * s - 6 * s) / h;
  const double d10 = 3 * s * s - 4 * s + 1;
  const double d01 = (-6 * s * s + 6 * s) / h;
  const double d11 = 3 * s * s - 2 * s;
  out.t = t;
  out.q = h00 * a.q + h10 * h * a.qd + h01 * b.q + h11 * h * b.qd;
  out.qd = d00 * a.q + d10 * a.qd + d01 * b.q + d11 * b.qd;
  out.qdd = (1.0 - s) * a.qdd + s * b.qdd;
  return true;
}

// ------------------------------------------------------------------------------ frame source

SensorFrameSource::SensorFrameSource(const SimSensorConfig& config,
                                     const drivers::can::SensorLayout& layout, model::RobotKinematics robot)
    : cell_([&] {
        sim::CellSimConfig c = config.cell;
        c.robot = std::move(robot);
        return c;
      }()),
      layout_(layout),
      rng_(config.cell.seed) {
  const sim::NoiseConfig& n = config.cell.noise;
  add_noise_ = n.wrench_std.maxCoeff() > 0.0 || n.acc_std > 0.0 || n.gyro_std > 0.0 ||
               n.alpha_std > 0.0 || n.temp_std > 0.0;
  for (auto& p : pending_) p.store(0);
  for (int i = 0; i < 6; ++i) {
    drivers::can::SignalCodec c;
    layout_.fieldCodec(static_cast<drivers::can::SensorField>(drivers::can::kFieldFx + i), c);
    wrench_max_[static_cast<std::size_t>(i)] =
        c.has_range ? std::max(std::fabs(c.minimum), std::fabs(c.maximum)) : 1e300;
  }
  drivers::can::SignalCodec fx;
  layout_.fieldCodec(drivers::can::kFieldFx, fx);
  if (fx.has_range) fx_fault_value_ = 1.2 * fx.maximum;
}

void SensorFrameSource::inject(SensorFault kind, int count) {
  pending_[static_cast<std::size_t>(kind)].fetch_add(std::max(count, 1));
}

sim::SensorReading SensorFrameSource::readingAt(const RobotHistory& history, double t_robot,
                                                double t_phys) {
  RobotHistory::Tick x;
  history.stateAt(t_robot, x);
  sim::SensorReading r = cell_.readingAt(x.q, x.qd, x.qdd, t_phys);
  const double tau = cell_.sensorDelay();
  if (tau > 0.0) {  // the wrench stream lags: the full reading of the instant t - tau
    RobotHistory::Tick xd;
    history.stateAt(t_robot - tau, xd);
    const sim::SensorReading rd = cell_.readingAt(xd.q, xd.qd, xd.qdd, t_phys - tau);
    r.wrench_S = rd.wrench_S;
    r.contact_S = rd.contact_S;
  }
  if (add_noise_) cell_.addNoise(r, rng_);
  return r;
}

int SensorFrameSource::nextSample(const RobotHistory& history, double t_robot, double t_phys,
                                  std::array<can_frame, kMaxFrames>& out) {
  const auto take = [&](SensorFault k) {
    return pending_[static_cast<std::size_t>(k)].exchange(0);
  };
  silent_left_ += take(SensorFault::kSilent);
  out_of_range_left_ += take(SensorFault::kOutOfRange);
  stuck_left_ += take(SensorFault::kStuckCounter);
  status_left_ += take(SensorFault::kStatusFault);
  counter_ += static_cast<std::uint32_t>(take(SensorFault::kCounterGap));
  const int error_frames = take(SensorFault::kErrorFrame);
  const int bus_off = take(SensorFault::kBusOff);
  if (contact_requested_.exchange(false)) {
    const auto& c = cell_.config().contact;
    const double length = c.t_end_s > c.t_start_s ? c.t_end_s - c.t_start_s : 2.0;
    cell_.setContactWindow(t_phys, t_phys + length);
  }
  if (grasp_requested_.exchange(false)) cell_.setPayloadChangeTime(t_phys);

  const sim::SensorReading r = readingAt(history, t_robot, t_phys);
  drivers::can::SensorValues v;
  v.wrench_S = r.wrench_S;
  v.acc_S = r.acc_S;
  v.w_S = r.w_S;
  v.alpha_S = r.alpha_S;
  v.temp_degC = r.temp_degC;
  v.status_word = 0;
  for (int i = 0; i < 6; ++i) {  // bit 0: a gauge beyond its rated range
    if (std::fabs(v.wrench_S[i]) > wrench_max_[static_cast<std::size_t>(i)]) v.status_word |= 0x1u;
  }
  if (status_left_ > 0) {
    v.status_word |= 0x2u;
    --status_left_;
  }
  if (out_of_range_left_ > 0) {
    v.wrench_S[0] = fx_fault_value_;  // a broken gauge: out of range without the overload bit
    --out_of_range_left_;
  }
  int n = 0;
  std::array<can_frame, drivers::can::SensorLayout::kMaxMessages> frames{};
  const std::uint32_t counter = counter_;
  if (stuck_left_ > 0) {
    --stuck_left_;
  } else {
    ++counter_;
  }
  if (silent_left_ > 0) {
    --silent_left_;
  } else {
    const int m = drivers::can::encodeSample(layout_, v, counter, frames);
    for (int i = 0; i < m; ++i) out[static_cast<std::size_t>(n++)] = frames[static_cast<std::size_t>(i)];
  }
  for (int e = 0; e < error_frames + bus_off && n < kMaxFrames; ++e) {
    can_frame f{};
    f.len = CAN_ERR_DLC;
    if (e < error_frames) {
      f.can_id = CAN_ERR_FLAG | CAN_ERR_CRTL;
      f.data[1] = CAN_ERR_CRTL_RX_WARNING;
    } else {
      f.can_id = CAN_ERR_FLAG | CAN_ERR_BUSOFF;
    }
    out[static_cast<std::size_t>(n++)] = f;
  }
  return n;
}

// ---------------------------------------------------------------------------------- runner

struct SimSensor::Impl {
  drivers::can::SensorLayout layout;
  std::unique_ptr<SensorFrameSource> source;
  std::unique_ptr<drivers::can::SeqpacketCanServer> server;
  std::unique_ptr<drivers::can::SocketCanTransport> socketcan;
  std::unique_ptr<std::ofstream> candump;
  RobotHistory history;
  mutable std::mutex stats_mutex;
  SimSensorStats stats;
  std::atomic<bool> robot_connected{false};
  std::atomic<std::uint64_t> robot_ticks{0};
  // Host (CLOCK_MONOTONIC) minus controller time, filtered by a windowed minimum [s].
  std::mutex offset_mutex;
  double offset_min_current = 1e300;
  double offset_min_previous = 1e300;
  int offset_window = 0;
  double offset() {
    std::lock_guard<std::mutex> lock(offset_mutex);
    return std::min(offset_min_current, offset_min_previous);
  }
  void resetOffset() {
    std::lock_guard<std::mutex> lock(offset_mutex);
    offset_min_current = offset_min_previous = 1e300;
    offset_window = 0;
  }
  void noteOffset(double o) {
    std::lock_guard<std::mutex> lock(offset_mutex);
    offset_min_current = std::min(offset_min_current, o);
    if (++offset_window >= 1000) {  // forget old minima slowly (clock drift)
      offset_min_previous = offset_min_current;
      offset_min_current = 1e300;
      offset_window = 0;
    }
  }

  // The RTDE reader thread (readRobot) and its steps; it runs until `stop` or `reader_stop`.
  void readRobot(const SimSensorConfig& config, const std::atomic<bool>& stop,
                 const std::atomic<bool>& reader_stop, const Progress& progress);
  void connectRobot(drivers::ur::RtdeClient& client, const SimSensorConfig& config,
                    const Progress& progress);
  void streamRobotStates(drivers::ur::RtdeClient& client, const std::atomic<bool>& stop,
                         const std::atomic<bool>& reader_stop, const Progress& progress);
  void addRobotState(const drivers::ur::RtdeStatePackage& st, const Progress& progress);
  struct SampleCycle;
};

/// RTDE reader: connect (retry every second), stream every state into the history.
void SimSensor::Impl::readRobot(const SimSensorConfig& config, const std::atomic<bool>& stop,
                                const std::atomic<bool>& reader_stop, const Progress& progress) {
  while (!reader_stop.load() && !stop.load()) {
    try {
      drivers::ur::RtdeClient client;
      connectRobot(client, config, progress);
      streamRobotStates(client, stop, reader_stop, progress);
    } catch (const std::exception& e) {
      if (robot_connected.exchange(false) || robot_ticks.load() == 0)
        say(progress, std::string("waiting for the robot: ") + e.what());
    }
    robot_connected = false;
    for (int i = 0; i < 10 && !reader_stop.load() && !stop.load(); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
}

/// Connects `client` to the robot and starts its state stream (the configured rate, else 500 Hz
/// from controller version 5 on and 125 Hz before); the robot counts as connected from then on.
void SimSensor::Impl::connectRobot(drivers::ur::RtdeClient& client, const SimSensorConfig& config,
                                   const Progress& progress) {
  client.connect(config.robot_host, config.rtde_port, std::chrono::milliseconds(1000));
  client.negotiateProtocolVersion();
  const auto version = client.controllerVersion();
  const double freq = config.rtde_frequency_hz > 0.0 ? config.rtde_frequency_hz
                      : version.major >= 5           ? 500.0
                                                     : 125.0;
  client.setupOutputs(freq, {"timestamp", "actual_q", "actual_qd", "target_qdd"});
  client.start();
  robot_connected = true;
  say(progress, "connected to RTDE " + config.robot_host + ":" + std::to_string(config.rtde_port) +
                    " (controller " + std::to_string(version.major) + "." +
                    std::to_string(version.minor) + ", " +
                    std::to_string(static_cast<int>(freq)) + " Hz)");
}

/// Takes the robot's states into the history until a stop or the stream is lost (said, for a
/// reconnect).
void SimSensor::Impl::streamRobotStates(drivers::ur::RtdeClient& client,
                                        const std::atomic<bool>& stop,
                                        const std::atomic<bool>& reader_stop,
                                        const Progress& progress) {
  drivers::ur::RtdeStatePackage st;
  while (!reader_stop.load() && !stop.load()) {
    const Status s = client.tryReceiveState(std::chrono::milliseconds(100), &st);
    if (s == Status::kTimeout) continue;
    if (s != Status::kOk) {
      say(progress, std::string("RTDE stream lost: ") + client.lastError() + "; reconnecting");
      break;
    }
    addRobotState(st, progress);
  }
}

/// One robot state into the history (a restarted controller clock resets it, and the offset) and
/// its host-minus-controller time into the offset filter.
void SimSensor::Impl::addRobotState(const drivers::ur::RtdeStatePackage& st,
                                    const Progress& progress) {
  RobotHistory::Tick tick;
  tick.t = st.timestamp;
  tick.q = toJoint(st.actual_q);
  tick.qd = toJoint(st.actual_qd);
  tick.qdd = toJoint(st.target_qdd);
  const std::uint64_t generation = history.generation();
  history.add(tick);
  if (history.generation() != generation) {
    resetOffset();
    say(progress, "the controller's clock restarted: robot history reset");
  }
  noteOffset(static_cast<double>(st.host_receive_ns) * 1e-9 - st.timestamp);
  ++robot_ticks;
}

// The sample clock: rt::runTimerClocked (absolute CLOCK_MONOTONIC deadlines). A stall of up to
// kCatchUpPeriods is caught up (late samples, sent back to back); after a longer one the clock
// re-anchors and the lost samples become a counter gap on the bus.
struct SimSensor::Impl::SampleCycle {
  SampleCycle(const SimSensor& s, Impl& i, const std::function<void(const std::string&)>& p)
      : self(s), im(i), progress(p) {}
  const SimSensor& self;
  Impl& im;
  const std::function<void(const std::string&)>& progress;
  std::int64_t period_ns = 0;
  double t_robot0 = 0.0;
  std::uint64_t generation = 0;
  double t_phys_last = 0.0;
  std::int64_t last_report_ns = 0;
  std::int64_t prev_deadline_ns = 0;
  std::uint64_t samples = 0, sent = 0, late = 0, skipped = 0;
  std::array<can_frame, SensorFrameSource::kMaxFrames> frames{};
  std::size_t next_fault = 0;
  std::vector<ScheduledSensorFault> schedule;
  std::exception_ptr error;

  rt::CycleAction onTimer(std::int64_t deadline_ns) noexcept {
    try {
      return sample(deadline_ns);
    } catch (...) {  // progress or the candump stream threw: end the loop, rethrown by run()
      error = std::current_exception();
      return rt::CycleAction::kStop;
    }
  }

  void say(const std::string& s) const {
    if (progress) progress(s);
  }

  /// One sample at its deadline: its instant in controller and physics time, the faults due,
  /// the frames on the bus, the statistics and the periodic progress line.
  rt::CycleAction sample(std::int64_t deadline_ns) {
    const SimSensorConfig& config = self.config();
    const std::int64_t now = rt::monotonicNs();
    if (last_report_ns == 0) last_report_ns = now;
    countMissedDeadlines(deadline_ns, now);
    followControllerRestart();
    // The sample's instant in controller time.
    const double t_robot = static_cast<double>(deadline_ns) * 1e-9 - im.offset();
    const double t_phys = t_robot - t_robot0;
    t_phys_last = t_phys;
    injectScheduledFaults(t_phys);
    const int n = im.source->nextSample(im.history, t_robot, t_phys, frames);
    sendFrames(n);
    sent += static_cast<std::uint64_t>(n);
    ++samples;
    publishStats(t_phys);
    if (now - last_report_ns >= 5'000'000'000 ||
        (config.verbose && now - last_report_ns >= 1'000'000'000)) {
      last_report_ns = now;
      reportProgress(t_phys);
    }
    if (config.duration_s > 0.0 && t_phys >= config.duration_s) return rt::CycleAction::kStop;
    return rt::CycleAction::kContinue;
  }

  /// Deadlines the re-anchored clock skipped become skipped samples and a counter gap; a sample
  /// more than a period behind its deadline counts as late.
  void countMissedDeadlines(std::int64_t deadline_ns, std::int64_t now) {
    if (prev_deadline_ns != 0 && deadline_ns - prev_deadline_ns > period_ns) {
      const std::int64_t missed = (deadline_ns - prev_deadline_ns) / period_ns - 1;
      skipped += static_cast<std::uint64_t>(missed);
      im.source->inject(SensorFault::kCounterGap, static_cast<int>(missed));
    } else if (now - deadline_ns > period_ns) {
      ++late;
    }
    prev_deadline_ns = deadline_ns;
  }

  /// After a controller restart (a new history generation) t_robot0 moves so that physics time
  /// goes on from the last sample's: t_phys = t_robot - t_robot0 stays continuous.
  void followControllerRestart() {
    if (im.history.generation() != generation) {
      generation = im.history.generation();
      t_robot0 = im.history.oldestTime() - t_phys_last;
    }
  }

  /// Injects the scheduled faults due at physics time t_phys (the schedule is sorted by time).
  void injectScheduledFaults(double t_phys) {
    while (next_fault < schedule.size() && schedule[next_fault].at_s <= t_phys) {
      im.source->inject(schedule[next_fault].kind, schedule[next_fault].count);
      say(std::string("injecting fault ") + sensorFaultName(schedule[next_fault].kind) + " x" +
          std::to_string(schedule[next_fault].count) + " at t=" + std::to_string(t_phys));
      ++next_fault;
    }
  }

  /// The sample's n frames to the socket's clients, the CAN interface and the candump log.
  void sendFrames(int n) {
    const std::int64_t rx_ns = drivers::can::realtimeNowNs();
    for (int i = 0; i < n; ++i) {
      const can_frame& f = frames[static_cast<std::size_t>(i)];
      im.server->trySend(f);
      if (im.socketcan) im.socketcan->trySend(f);
      if (im.candump) {
        drivers::can::ReceivedFrame rf;
        rf.frame = f;
        rf.rx_time_ns = rx_ns;
        *im.candump << drivers::can::formatCandumpLine(rf, "can0") << '\n';
      }
    }
  }

  /// The counts so far into the statistics stats() reads.
  void publishStats(double t_phys) {
    std::lock_guard<std::mutex> lock(im.stats_mutex);
    im.stats.samples = samples;
    im.stats.frames_sent = sent;
    im.stats.frames_dropped = im.server->framesDropped();
    im.stats.late_samples = late;
    im.stats.skipped_samples = skipped;
    im.stats.clients = im.server->clientCount();
    im.stats.t_phys = t_phys;
  }

  /// The progress line: physics time, samples, frames, clients, robot ticks, drops and late samples.
  void reportProgress(double t_phys) const {
    std::ostringstream os;
    os << "t=" << std::fixed;
    os.precision(1);
    os << t_phys << " s  samples=" << samples << "  frames=" << sent
       << "  clients=" << im.server->clientCount() << "  robot_ticks=" << im.robot_ticks.load()
       << (im.robot_connected.load() ? "" : " (robot disconnected)")
       << "  dropped=" << im.server->framesDropped() << "  late=" << late;
    say(os.str());
  }
};

SimSensor::SimSensor(SimSensorConfig config) : config_(std::move(config)), impl_(new Impl) {
  if (!(config_.rate_hz > 0.0 && config_.rate_hz <= 10000.0))
    throw ConfigError("rate_hz must be in (0, 10000] Hz, got " + std::to_string(config_.rate_hz));
  impl_->layout = drivers::can::SensorLayout::fromDbc(drivers::can::loadDbc(config_.dbc_path));
  impl_->source = std::make_unique<SensorFrameSource>(
      config_, impl_->layout, model::RobotKinematics::fromUrdfFile(config_.urdf_path));
  impl_->server = std::make_unique<drivers::can::SeqpacketCanServer>(config_.socket_path);
  if (!config_.can_interface.empty()) {
    drivers::can::SocketCanOptions o;
    o.interface = config_.can_interface;
    o.error_mask = 0;
    impl_->socketcan = std::make_unique<drivers::can::SocketCanTransport>(o);
  }
  if (!config_.candump_log.empty()) {
    impl_->candump = std::make_unique<std::ofstream>(config_.candump_log);
    if (!*impl_->candump) throw ConfigError("cannot write candump log " + config_.candump_log);
  }
}

SimSensor::~SimSensor() = default;

void SimSensor::inject(SensorFault kind, int count) { impl_->source->inject(kind, count); }

void SimSensor::startContactPush() noexcept { impl_->source->requestContactPush(); }
void SimSensor::startGrasp() noexcept { impl_->source->requestGrasp(); }

SimSensorStats SimSensor::stats() const {
  std::lock_guard<std::mutex> lock(impl_->stats_mutex);
  SimSensorStats s = impl_->stats;
  s.robot_ticks = impl_->robot_ticks.load();
  s.robot_connected = impl_->robot_connected.load();
  return s;
}

void SimSensor::run(const std::atomic<bool>& stop,
                    const std::function<void(const std::string&)>& progress) {
  Impl& im = *impl_;
  std::atomic<bool> reader_stop{false};
  std::thread reader([&] { im.readRobot(config_, stop, reader_stop, progress); });

  // Wait for the first robot state.
  while (!stop.load() && im.history.empty())
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  if (stop.load()) {
    reader_stop = true;
    reader.join();
    return;
  }
  // Physics time = controller time - t_robot0; kept continuous across controller restarts.
  double t_robot0 = im.history.oldestTime();
  std::uint64_t generation = im.history.generation();
  say(progress, "emitting " + std::to_string(static_cast<int>(config_.rate_hz)) + " Hz samples on " +
                    config_.socket_path +
                    (config_.can_interface.empty() ? "" : " and " + config_.can_interface));

  Impl::SampleCycle cycle(*this, im, progress);
  cycle.period_ns = static_cast<std::int64_t>(std::llround(1e9 / config_.rate_hz));
  cycle.t_robot0 = t_robot0;
  cycle.generation = generation;
  cycle.schedule = config_.faults;
  std::sort(cycle.schedule.begin(), cycle.schedule.end(),
            [](const auto& a, const auto& b) { return a.at_s < b.at_s; });
  rt::ExecutorConfig ec;
  ec.period = std::chrono::nanoseconds(cycle.period_ns);
  ec.catch_up_periods = kCatchUpPeriods;
  rt::LoopStats loop_stats;
  rt::runTimerClocked(cycle, ec, &loop_stats, &stop);
  if (im.candump) im.candump->flush();
  reader_stop = true;
  reader.join();
  if (cycle.error) std::rethrow_exception(cycle.error);
}

}  // namespace ftid::simsensor
