#pragma once
// Records ftidd's synchronised cycle samples (robot state + raw sensor, LCM channel FTID_CYCLE)
// on a normal-priority thread, and exposes how long ago the last one arrived so a real-time loop
// can notice that ftidd stopped (ftidd killed, sensor silent).
#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "ftid/logio/log.hpp"
#include "ftid/transport/records.hpp"

namespace ftid::cell {

/// Monotonic clock in ns (CLOCK_MONOTONIC), the time base of lastReceiveNs().
std::int64_t monotonicNowNs() noexcept;

class CycleRecorder {
 public:
  /// capacity: records kept at most (older ones are kept, later ones counted as dropped).
  CycleRecorder(std::string lcm_url, std::string channel, std::size_t capacity);
  ~CycleRecorder();
  CycleRecorder(const CycleRecorder&) = delete;
  CycleRecorder& operator=(const CycleRecorder&) = delete;

  /// Creates the LCM instance and the receive thread. Throws DriverError naming the URL if LCM
  /// cannot be created (e.g. no multicast route).
  void start();
  void stop() noexcept;

  /// Blocks until `n` records have arrived since start() (or since clear()), or the timeout.
  bool waitForRecords(std::size_t n, std::chrono::milliseconds timeout) const;
  /// Forgets what was recorded so far (non-RT).
  void clear();
  /// Copy of the records (non-RT).
  std::vector<transport::CycleRecord> snapshot() const;

  // Real-time readable (atomics only).
  std::int64_t lastReceiveNs() const noexcept { return last_receive_ns_.load(std::memory_order_relaxed); }
  /// Consecutive records whose sensor sample was invalid or stale (0 after a valid one).
  std::int64_t invalidSensorStreak() const noexcept { return invalid_streak_.load(std::memory_order_relaxed); }
  std::size_t count() const noexcept { return count_.load(std::memory_order_relaxed); }
  std::size_t dropped() const noexcept { return dropped_.load(std::memory_order_relaxed); }

 private:
  struct Impl;
  void onMessage(const void* data, std::size_t size);
  std::string url_;
  std::string channel_;
  std::size_t capacity_;
  std::unique_ptr<Impl> impl_;
  mutable std::mutex mutex_;
  std::vector<transport::CycleRecord> records_;
  std::atomic<bool> running_{false};
  std::thread thread_;
  std::atomic<std::int64_t> last_receive_ns_{0};
  std::atomic<std::int64_t> invalid_streak_{0};
  std::atomic<std::size_t> count_{0};
  std::atomic<std::size_t> dropped_{0};
};

struct RecordsToLogReport {
  std::size_t converted = 0;
  std::size_t skipped_invalid = 0;        ///< robot state or sensor sample invalid/stale
  std::size_t skipped_non_monotonic = 0;  ///< robot time not strictly increasing
};

/// Converts cycle records to the CSV log format (docs/log-format.md): t = robot time [s],
/// q/qd/qdd from the robot state, the raw wrench, IMU and temperature from the sensor sample.
/// Records with an invalid robot state or sensor sample are dropped (never fitted as valid).
/// Only records with t_min <= robot_time <= t_max are kept.
logio::LogData recordsToLog(const std::vector<transport::CycleRecord>& records, double t_min,
                            double t_max, const std::string& source, RecordsToLogReport* report = nullptr);

}  // namespace ftid::cell
