#include "ftid/cell/cycle_recorder.hpp"

#include <time.h>

#include <lcm/lcm-cpp.hpp>

#include "ftid/common/error.hpp"
#include "ftid/transport/codec.hpp"
#include "ftid/transport/lcm_to_csv.hpp"

namespace ftid::cell {

std::int64_t monotonicNowNs() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
}

struct CycleRecorder::Impl {
  std::unique_ptr<lcm::LCM> lcm;
  lcm::Subscription* subscription = nullptr;
  CycleRecorder* owner = nullptr;
  void handle(const lcm::ReceiveBuffer* rbuf, const std::string& /*channel*/) {
    owner->onMessage(rbuf->data, rbuf->data_size);
  }
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
  running_ = true;
  thread_ = std::thread([this] {
    while (running_.load()) impl_->lcm->handleTimeout(50);
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
}

void CycleRecorder::onMessage(const void* data, std::size_t size) {
  ftid_lcm::cycle_sample_t msg;
  if (!transport::decodeFrom(data, size, &msg)) return;
  transport::CycleRecord rec;
  transport::fromLcm(msg, &rec);
  last_receive_ns_.store(monotonicNowNs(), std::memory_order_relaxed);
  const bool sensor_ok = rec.sensor.valid && rec.sensor.health_flags == transport::kHealthOk;
  if (sensor_ok) {
    invalid_streak_.store(0, std::memory_order_relaxed);
  } else {
    invalid_streak_.fetch_add(1, std::memory_order_relaxed);
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

std::vector<transport::CycleRecord> CycleRecorder::snapshot() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return records_;
}

logio::LogData recordsToLog(const std::vector<transport::CycleRecord>& records, double t_min,
                            double t_max, const std::string& source, RecordsToLogReport* report) {
  RecordsToLogReport rep;
  transport::CycleLogBuilder builder(source);
  for (const auto& r : records) {
    if (r.robot.robot_time < t_min || r.robot.robot_time > t_max) continue;
    if (r.sensor.health_flags != transport::kHealthOk) {  // stale/gap/error: never fitted as valid
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
