#include "ftid/common/clock.hpp"
#include "ftid/cell/cycle_recorder.hpp"

#include <pthread.h>
#include <sched.h>
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <lcm/lcm-cpp.hpp>

#include "ftid/common/error.hpp"
#include "ftid/transport/codec.hpp"
#include "ftid/transport/lcm_to_csv.hpp"

namespace ftid::cell {

struct CycleRecorder::Impl {
  std::unique_ptr<lcm::LCM> lcm;
  lcm::Subscription* subscription = nullptr;
  CycleRecorder* owner = nullptr;
  // Nothing may escape into LCM's C callback: onMessage decodes with transport::decodeFrom
  // (malformed bytes are dropped), and an error of the stream it appends to is reported once.
  void handle(const lcm::ReceiveBuffer* rbuf, const std::string& /*channel*/) noexcept {
    try {
      owner->onMessage(rbuf->data, rbuf->data_size);
    } catch (const std::exception& e) {
      if (!reported) std::fprintf(stderr, "cycle recorder: %s\n", e.what());
      reported = true;
    } catch (...) {
      if (!reported) std::fprintf(stderr, "cycle recorder: unknown error handling a message\n");
      reported = true;
    }
  }
  bool reported = false;
};

CycleRecorder::CycleRecorder(std::string lcm_url, std::string channel, std::size_t capacity)
    : url_(std::move(lcm_url)), channel_(std::move(channel)), capacity_(capacity) {
  records_.reserve(capacity_);
}

CycleRecorder::~CycleRecorder() { stop(); }

void CycleRecorder::start() {
  impl_ = std::make_unique<Impl>();
  impl_->owner = this;
  impl_->lcm = std::make_unique<lcm::LCM>(url_);
  if (!impl_->lcm->good()) {
    throw DriverError("LCM: cannot open '" + url_ +
                      "' (for udpm a multicast route is needed, e.g. ip route add 224.0.0.0/4 dev lo)");
  }
  transport::warmUpCodec();
  impl_->subscription = impl_->lcm->subscribe(channel_, &Impl::handle, impl_.get());
  impl_->subscription->setQueueCapacity(2000);
  if (!allowed_.empty()) transport::restrictLcmSources(*impl_->lcm, url_, allowed_);
  running_ = true;
  last_poll_ns_.store(monotonicNs());
  thread_ = std::thread([this] {
    // A low real-time priority where permitted: on an overloaded host a starved receive thread
    // would look like a silent ftidd (the motion loop runs at a higher one).
    sched_param sp{};
    sp.sched_priority = 5;
    (void)pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
    while (running_.load()) {
      last_poll_ns_.store(monotonicNs(), std::memory_order_relaxed);
      impl_->lcm->handleTimeout(50);
    }
  });
}

void CycleRecorder::stop() noexcept {
  running_ = false;
  if (thread_.joinable()) thread_.join();
  if (impl_ && impl_->lcm && impl_->subscription) {
    impl_->lcm->unsubscribe(impl_->subscription);
    impl_->subscription = nullptr;
  }
  impl_.reset();
  if (stream_) stream_->finish();
}

void CycleRecorder::onMessage(const void* data, std::size_t size) {
  ftid_lcm::cycle_sample_t msg;
  if (!transport::decodeFrom(data, size, &msg)) return;
  CycleRecord rec;
  transport::fromLcm(msg, &rec);
  if (stream_) stream_->append(rec);
  // Liveness and the sensor streak follow ftidd's cycles, not datagrams: a repeated or forged
  // copy of an old cycle neither keeps the watch alive nor counts twice (the stream check after
  // the run judges the copies).
  if (!have_cycle_ || rec.cycle > newest_cycle_) {
    have_cycle_ = true;
    newest_cycle_ = rec.cycle;
    last_receive_ns_.store(monotonicNs(), std::memory_order_relaxed);
    const bool sensor_ok = rec.sensor.valid && rec.sensor.health_flags == kHealthOk;
    if (sensor_ok) {
      invalid_streak_.store(0, std::memory_order_relaxed);
    } else {
      invalid_streak_.fetch_add(1, std::memory_order_relaxed);
    }
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (records_.size() < capacity_) {
    records_.push_back(rec);
  } else {
    dropped_.fetch_add(1, std::memory_order_relaxed);
  }
  count_.store(records_.size(), std::memory_order_relaxed);
}

bool CycleRecorder::waitForRecords(std::size_t n, std::chrono::milliseconds timeout) const {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (count() < n) {
    if (std::chrono::steady_clock::now() >= deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return true;
}

void CycleRecorder::clear() {
  std::lock_guard<std::mutex> lock(mutex_);
  records_.clear();
  count_.store(0);
}

std::vector<CycleRecord> CycleRecorder::snapshot() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return records_;
}

namespace {

bool sameContent(const CycleRecord& a, const CycleRecord& b) {
  return a.cycle == b.cycle && a.utime == b.utime && a.robot.robot_time == b.robot.robot_time &&
         a.robot.q == b.robot.q && a.robot.qd == b.robot.qd && a.robot.qdd == b.robot.qdd &&
         a.robot.valid == b.robot.valid && a.sensor.recv_utime == b.sensor.recv_utime &&
         a.sensor.counter == b.sensor.counter && a.sensor.wrench_S == b.sensor.wrench_S &&
         a.sensor.imu_acc_S == b.sensor.imu_acc_S && a.sensor.imu_w_S == b.sensor.imu_w_S &&
         a.sensor.temp_degC == b.sensor.temp_degC && a.sensor.health_flags == b.sensor.health_flags &&
         a.sensor.valid == b.sensor.valid;
}

}  // namespace

bool CycleStreamReport::ok() const noexcept {
  if (conflicts > 0 || bad_spacing > 0 || bad_sequence > 0) return false;
  if (unique > expected) return false;
  return expected == 0 ||
         static_cast<double>(missing) <= max_missing_fraction * static_cast<double>(expected);
}

std::string CycleStreamReport::describe() const {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "%zu cycle samples received, %zu unique, %zu expected from the controller rate; "
                "%zu exact duplicates dropped, %zu missing (gaps), %zu conflicting, %zu off the "
                "controller's period grid, %zu out of sequence",
                received, unique, expected, exact_duplicates, missing, conflicts, bad_spacing,
                bad_sequence);
  std::string s = buf;
  if (ok()) return s;
  if (conflicts > 0) s += "; records share a cycle number or robot time with different values (a second publisher on the cycle channel?)";
  if (bad_spacing > 0 || bad_sequence > 0) s += "; the stream does not follow the controller's clock";
  if (unique > expected) s += "; more samples than the controller produced";
  if (expected > 0 && static_cast<double>(missing) > max_missing_fraction * static_cast<double>(expected)) {
    s += "; too many samples missing";
  }
  return s;
}

CycleStreamReport checkCycleStream(const std::vector<CycleRecord>& records, double rate_hz,
                                   double t_min, double t_max, std::vector<CycleRecord>* clean) {
  CycleStreamReport rep;
  const double period = 1.0 / rate_hz;
  std::vector<CycleRecord> in;
  double prev_t = -1e300;
  for (const auto& r : records) {
    const double t = r.robot.robot_time;
    if (!(t >= t_min && t <= t_max)) continue;
    if (t < prev_t) ++rep.out_of_order;
    prev_t = t;
    in.push_back(r);
  }
  rep.received = in.size();
  std::stable_sort(in.begin(), in.end(), [](const CycleRecord& a, const CycleRecord& b) {
    return a.robot.robot_time < b.robot.robot_time ||
           (a.robot.robot_time == b.robot.robot_time && a.cycle < b.cycle);
  });
  std::vector<CycleRecord> out;
  out.reserve(in.size());
  for (const auto& r : in) {
    if (!out.empty() && r.robot.robot_time == out.back().robot.robot_time) {
      if (sameContent(r, out.back())) {
        ++rep.exact_duplicates;
      } else {
        ++rep.conflicts;
      }
      continue;
    }
    out.push_back(r);
  }
  // Same cycle number at different robot times is a conflict too.
  std::vector<std::int64_t> cycles;
  cycles.reserve(out.size());
  for (const auto& r : out) cycles.push_back(r.cycle);
  std::sort(cycles.begin(), cycles.end());
  for (std::size_t i = 1; i < cycles.size(); ++i) {
    if (cycles[i] == cycles[i - 1]) ++rep.conflicts;
  }
  for (std::size_t i = 1; i < out.size(); ++i) {
    const double steps = (out[i].robot.robot_time - out[i - 1].robot.robot_time) / period;
    const double k = std::round(steps);
    if (k < 1.0 || std::abs(steps - k) > 0.25) ++rep.bad_spacing;
    const std::int64_t dc = out[i].cycle - out[i - 1].cycle;
    if (dc < 1 || static_cast<double>(dc) > k + 0.5) ++rep.bad_sequence;
  }
  rep.unique = out.size();
  if (!out.empty()) {
    rep.expected = static_cast<std::size_t>(
                       std::llround((out.back().robot.robot_time - out.front().robot.robot_time) / period)) +
                   1;
  }
  rep.missing = rep.expected > rep.unique ? rep.expected - rep.unique : 0;
  if (clean) *clean = std::move(out);
  return rep;
}

logio::LogData recordsToLog(const std::vector<CycleRecord>& records, double t_min,
                            double t_max, const std::string& source, RecordsToLogReport* report) {
  RecordsToLogReport rep;
  transport::CycleLogBuilder builder(source);
  for (const auto& r : records) {
    if (r.robot.robot_time < t_min || r.robot.robot_time > t_max) continue;
    if (r.sensor.health_flags != kHealthOk) {  // stale/gap/error: never fitted as valid
      ++rep.skipped_invalid;
      continue;
    }
    builder.add(r);
  }
  rep.converted = builder.report().converted;
  rep.skipped_invalid += builder.report().skipped_invalid + builder.report().skipped_non_finite;
  rep.skipped_non_monotonic = builder.report().skipped_non_monotonic;
  if (report) *report = rep;
  return builder.finish();
}

}  // namespace ftid::cell
