#pragma once
// ftidd's payload monitor (docs/daemon.md, "Payload monitor"), off the real-time loop:
//
//   loop (DaemonCycle::step)   every valid cycle: MonitorLink::handOver(sample) - a wait-free
//                              SPSC push, allocation-free (dropped and counted when full); every
//                              compensated wrench gets the link's current flags (kFlagPayload*)
//   monitor thread (here)      drains the queue every 10 ms into monitor::PayloadMonitor, sets the
//                              flags, publishes a report at publish_hz and at once on each event;
//                              a new parameter version resets the monitor
//   supervisor                 reads the latest report (REIDENTIFY, status)
#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "ftid/config/daemon_config.hpp"
#include "ftid/monitor/change_fit.hpp"
#include "ftid/monitor/payload_monitor.hpp"
#include "ftid/params/parameter_set.hpp"
#include "ftid/rt/spsc_queue.hpp"

namespace ftid_lcm {
class payload_monitor_t;
}
namespace ftid::transport {
class LcmOutbox;
}

namespace ftid::daemon {

/// One sample handed from the loop to the monitor thread.
struct MonitorInput {
  monitor::MonitorSample sample;
  std::int32_t param_version = 0;
};

/// The hand-over between the loop and the monitor thread (allocate once, at set-up).
struct MonitorLink {
  static constexpr std::size_t kCapacity = 1024;  ///< 8 s at 125 Hz, 2 s at 500 Hz
  rt::SpscQueue<MonitorInput, kCapacity> queue;
  std::atomic<std::uint32_t> wrench_flags{0};     ///< kFlagPayloadSuspect / kFlagPayloadChanged
  std::atomic<std::uint64_t> dropped{0};

  /// Loop side: never blocks, allocates or throws.
  void handOver(const MonitorInput& input) noexcept {
    if (!queue.tryPush(input)) dropped.fetch_add(1, std::memory_order_relaxed);
  }
  std::uint32_t flags() const noexcept { return wrench_flags.load(std::memory_order_relaxed); }
};

/// What the monitor thread publishes.
struct MonitorReport {
  monitor::MonitorStatus status;
  std::optional<monitor::MonitorEvent> event;
  std::int32_t param_version = 0;
  std::uint64_t dropped = 0;
  std::int64_t utime = 0;
};

/// The monitor's settings from ftidd's configuration.
monitor::MonitorSettings monitorSettings(const config::MonitorConfig& config);

/// The LCM message of a report (payload_monitor_t, version 1).
ftid_lcm::payload_monitor_t toMessage(const MonitorReport& report);

/// Publishes the report on `channel` through the outbox (non-RT) and logs an event in one line.
void publishMonitorReport(transport::LcmOutbox* outbox, const std::string& channel, const MonitorReport& report);

/// [m, m c, I_S] of a parameter set (the inertia NaN when the set has none). Throws ConfigError
/// if it has no mass or first moment (a model without `gravity`).
monitor::ChangeVector payloadOf(const params::ParameterSet& set);

/// The set after a fitted change: mass, mass_com_* and (if present) i_s_* plus the change, with
/// the change's standard errors; derived values dropped; provenance says "reidentify".
params::ParameterSet reidentifiedSet(const params::ParameterSet& set, const monitor::ChangeFit& fit);

class PayloadWatch {
 public:
  using Publisher = std::function<void(const MonitorReport& report)>;

  /// Validates the settings (ConfigError naming the key); `publish` is called from the monitor
  /// thread (or from poll()).
  /// `history` samples are kept for recent() (at least one).
  PayloadWatch(const monitor::MonitorSettings& settings, double publish_hz, MonitorLink* link, Publisher publish,
               std::size_t history = 4096);
  ~PayloadWatch();
  PayloadWatch(const PayloadWatch&) = delete;
  PayloadWatch& operator=(const PayloadWatch&) = delete;

  void start();  ///< the monitor thread (normal priority)
  void stop();   ///< idempotent

  /// One pass of the thread (tests drive it without the thread): drains the queue, updates the
  /// monitor and the flags, publishes each event and, when `mono_now_us` (CLOCK_MONOTONIC) is a
  /// period past the last report, the status. now_us (CLOCK_REALTIME) stamps the reports' utime.
  void poll(std::int64_t now_us, std::int64_t mono_now_us);

  /// The kept samples of the newest parameter version from the last `window_s` (sample time), in
  /// order (any thread).
  std::vector<monitor::MonitorSample> recent(double window_s) const;
  const monitor::MonitorSettings& settings() const noexcept { return monitor_.settings(); }

  /// The monitor's state after the last poll (any thread; `event` is set only if that poll published one).
  MonitorReport latest() const;

 private:
  void publish(const MonitorReport& report);

  monitor::PayloadMonitor monitor_;
  std::int64_t period_us_;
  MonitorLink* link_;
  Publisher publish_;
  std::int32_t param_version_ = -1;
  std::int64_t last_report_mono_us_ = 0;  ///< CLOCK_MONOTONIC of the last periodic report
  mutable std::mutex mutex_;
  MonitorReport latest_;
  std::vector<MonitorInput> history_;  ///< ring, fixed capacity
  std::size_t history_next_ = 0;
  std::size_t history_count_ = 0;
  std::atomic<bool> running_{false};
  std::thread thread_;
};

}  // namespace ftid::daemon
