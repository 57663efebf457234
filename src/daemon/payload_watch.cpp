// ftidd's payload monitor thread (include/ftid/daemon/payload_watch.hpp).
#include "ftid/daemon/payload_watch.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <vector>

#include "daemon_setup.hpp"

#include "ftid/common/error.hpp"
#include "ftid/common/status.hpp"
#include "ftid/daemon/daemon_cycle.hpp"
#include "ftid_lcm/payload_monitor_t.hpp"

namespace ftid::daemon {

monitor::MonitorSettings monitorSettings(const config::MonitorConfig& c) {
  monitor::MonitorSettings s;
  s.noise_std = c.noise_std;
  s.onset_margin = c.onset_margin;
  s.onset_threshold = c.onset_threshold;
  s.decision_threshold = c.decision_threshold;
  s.contact_force_std_N = c.contact_force_std_N;
  s.contact_torque_std_Nm = c.contact_torque_std_Nm;
  s.contact_force_rate_N_s = c.contact_force_rate_N_s;
  s.contact_torque_rate_Nm_s = c.contact_torque_rate_Nm_s;
  s.prior_mass_std_kg = c.prior_mass_std_kg;
  s.prior_mass_com_std_kg_m = c.prior_mass_com_std_kg_m;
  s.prior_inertia_std_kg_m2 = c.prior_inertia_std_kg_m2;
  s.free_motion_turn_rad_s = c.free_motion_turn_rad_s;
  s.free_motion_acc_m_s2 = c.free_motion_acc_m_s2;
  s.max_gap_s = c.max_gap_s;
  s.restart_s = c.restart_s;
  s.min_change_s = c.min_change_s;
  return s;
}

ftid_lcm::payload_monitor_t toMessage(const MonitorReport& r) {
  ftid_lcm::payload_monitor_t m{};
  m.version = ftid_lcm::payload_monitor_t::VERSION;
  m.utime = r.utime;
  m.state = static_cast<std::int8_t>(r.status.state);
  m.param_version = r.param_version;
  m.t = r.status.t;
  m.onset_t = r.status.onset_t;
  m.samples = r.status.samples;
  m.free_motion_samples = r.status.free_samples;
  m.log_bf_change = r.status.log_bf_change;
  m.log_bf_contact = r.status.log_bf_contact;
  m.cusum = r.status.cusum;
  const monitor::ChangeEstimate& c = r.event ? r.event->change : r.status.change;
  m.delta_mass = c.delta_mass_kg;
  m.delta_mass_std = c.delta_mass_std_kg;
  for (int i = 0; i < 3; ++i) {
    m.delta_com[i] = c.delta_com_m[i];
    m.delta_com_std[i] = c.delta_com_std_m[i];
    m.delta_mass_com[i] = c.delta_mass_com_kg_m[i];
  }
  m.event_kind = ftid_lcm::payload_monitor_t::EVENT_NONE;
  m.event_t = 0.0;
  if (r.event) {
    m.event_kind = r.event->kind == monitor::EventKind::kPayloadChange ? ftid_lcm::payload_monitor_t::EVENT_PAYLOAD_CHANGE
                                                                       : ftid_lcm::payload_monitor_t::EVENT_CONTACT;
    m.event_t = r.event->t_decided;
  }
  m.samples_dropped = static_cast<std::int64_t>(r.dropped);
  return m;
}

void publishMonitorReport(transport::LcmOutbox* outbox, const std::string& channel, const MonitorReport& report) {
  const ftid_lcm::payload_monitor_t msg = toMessage(report);
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(msg.getEncodedSize()));
  if (msg.encode(buf.data(), 0, static_cast<int>(buf.size())) < 0) return;
  if (outbox != nullptr) outbox->publishRaw(channel, buf.data(), static_cast<unsigned>(buf.size()));
  if (report.event) {
    const monitor::MonitorEvent& e = *report.event;
    char line[256];
    std::snprintf(line, sizeof line, "payload monitor: %s at t=%.3f s (onset %.3f s): delta_mass %+.3f +- %.3f kg",
                  monitor::eventName(e.kind), e.t_decided, e.t_onset, e.change.delta_mass_kg,
                  e.change.delta_mass_std_kg);
    logLine(line);
  }
}

PayloadWatch::PayloadWatch(const monitor::MonitorSettings& settings, double publish_hz, MonitorLink* link,
                           Publisher publish, std::size_t history)
    : monitor_(settings),
      period_us_(static_cast<std::int64_t>(std::llround(1e6 / publish_hz))),
      link_(link),
      publish_(std::move(publish)),
      history_(std::max<std::size_t>(history, 1)) {}

PayloadWatch::~PayloadWatch() { stop(); }

void PayloadWatch::start() {
  if (running_.exchange(true)) return;
  thread_ = std::thread([this] {
    while (running_.load()) {
      poll(realtimeNowUs(), monotonicNowUs());
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
  });
}

void PayloadWatch::stop() {
  running_.store(false);
  if (thread_.joinable()) thread_.join();
}

void PayloadWatch::publish(const MonitorReport& report) {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    latest_ = report;
  }
  if (publish_) publish_(report);
}

void PayloadWatch::poll(std::int64_t now_us, std::int64_t mono_now_us) {
  MonitorInput in;
  while (link_->queue.tryPop(&in)) {
    if (in.param_version != param_version_) {
      // New parameters (a reload, tare or re-identification): the residual starts over.
      monitor_.reset();
      param_version_ = in.param_version;
    }
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      history_[history_next_] = in;
      history_next_ = (history_next_ + 1) % history_.size();
      history_count_ = std::min(history_count_ + 1, history_.size());
    }
    const std::optional<monitor::MonitorEvent> event = monitor_.update(in.sample);
    const monitor::MonitorState state = monitor_.status().state;
    link_->wrench_flags.store(state == monitor::MonitorState::kChanged   ? kFlagPayloadChanged
                              : state == monitor::MonitorState::kSuspect ? kFlagPayloadSuspect
                                                                         : 0u,
                              std::memory_order_relaxed);
    if (event) {
      MonitorReport r;
      r.status = monitor_.status();
      r.event = event;
      r.param_version = param_version_;
      r.dropped = link_->dropped.load(std::memory_order_relaxed);
      r.utime = now_us;
      publish(r);
    }
  }
  MonitorReport r;
  r.status = monitor_.status();
  r.param_version = param_version_;
  r.dropped = link_->dropped.load(std::memory_order_relaxed);
  r.utime = now_us;
  if (mono_now_us - last_report_mono_us_ >= period_us_) {  // a real-time step changes no period
    last_report_mono_us_ = mono_now_us;
    publish(r);
  } else {
    const std::lock_guard<std::mutex> lock(mutex_);
    latest_ = r;
  }
}

std::vector<monitor::MonitorSample> PayloadWatch::recent(double window_s) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  std::vector<monitor::MonitorSample> out;
  if (history_count_ == 0) return out;
  const std::size_t n = history_.size();
  const MonitorInput& newest = history_[(history_next_ + n - 1) % n];
  // Walk back from the newest while the version and the window hold.
  std::size_t k = 0;
  while (k < history_count_) {
    const MonitorInput& in = history_[(history_next_ + n - 1 - k) % n];
    if (in.param_version != newest.param_version || in.sample.t < newest.sample.t - window_s) break;
    ++k;
  }
  out.reserve(k);
  for (std::size_t i = k; i > 0; --i) out.push_back(history_[(history_next_ + n - i) % n].sample);
  return out;
}

monitor::ChangeVector payloadOf(const params::ParameterSet& set) {
  static constexpr const char* kNames[monitor::kChangeParams] = {
      "mass", "mass_com_x", "mass_com_y", "mass_com_z", "i_s_xx", "i_s_yy", "i_s_zz", "i_s_xy", "i_s_xz", "i_s_yz"};
  monitor::ChangeVector p = monitor::ChangeVector::Constant(std::nan(""));
  for (const params::NamedValue& v : set.params) {
    for (int j = 0; j < monitor::kChangeParams; ++j) {
      if (v.name == kNames[j]) p[j] = v.value;
    }
  }
  if (!p.head<4>().allFinite()) {
    throw ConfigError("re-identification needs a payload with mass and mass_com_x/y/z (model '" + set.model + "')");
  }
  return p;
}

params::ParameterSet reidentifiedSet(const params::ParameterSet& set, const monitor::ChangeFit& fit) {
  static constexpr const char* kNames[monitor::kChangeParams] = {
      "mass", "mass_com_x", "mass_com_y", "mass_com_z", "i_s_xx", "i_s_yy", "i_s_zz", "i_s_xy", "i_s_xz", "i_s_yz"};
  params::ParameterSet next = set;
  for (params::NamedValue& v : next.params) {
    for (int j = 0; j < monitor::kChangeParams; ++j) {
      if (v.name != kNames[j]) continue;
      v.value += fit.change.delta[j];
      v.std = std::sqrt(std::max(0.0, fit.change.covariance(j, j)));
    }
  }
  next.derived.clear();
  next.provenance.method = "reidentify";
  next.provenance.n_samples = fit.samples;
  return next;
}

MonitorReport PayloadWatch::latest() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return latest_;
}

}  // namespace ftid::daemon
