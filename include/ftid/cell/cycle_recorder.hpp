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

#include "ftid/common/clock.hpp"  // monotonicNs(): the time base of lastReceiveNs()
#include "ftid/cell/run_stream.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/common/records.hpp"
#include "ftid/transport/source_filter.hpp"

namespace ftid::cell {

class CycleRecorder {
 public:
  /// capacity: records kept at most (older ones are kept, later ones counted as dropped).
  CycleRecorder(std::string lcm_url, std::string channel, std::size_t capacity);
  ~CycleRecorder();
  CycleRecorder(const CycleRecorder&) = delete;
  CycleRecorder& operator=(const CycleRecorder&) = delete;

  /// Before start(): receive only datagrams from these sources (kernel socket filter on the udpm
  /// receive socket; ftid/transport/source_filter.hpp). Empty (default) = any source.
  void restrictSources(std::vector<transport::Ipv4Net> allowed) { allowed_ = std::move(allowed); }
  /// Before start(): also append every record to this stream as it arrives (on the receive
  /// thread); stop() finishes it (fsync). The recorder keeps it; see stream().
  void streamTo(std::unique_ptr<RunStreamWriter> writer) { stream_ = std::move(writer); }
  /// The stream (nullptr if none); read its counters after stop().
  const RunStreamWriter* stream() const noexcept { return stream_.get(); }

  /// Creates the LCM instance and the receive thread. Throws DriverError naming the URL if LCM
  /// cannot be created (e.g. no multicast route) or the source filter cannot be installed.
  void start();
  void stop() noexcept;

  /// Blocks until `n` records have arrived since start() (or since clear()), or the timeout.
  bool waitForRecords(std::size_t n, std::chrono::milliseconds timeout) const;
  /// Forgets what was recorded so far (non-RT).
  void clear();
  /// Copy of the records (non-RT).
  std::vector<CycleRecord> snapshot() const;

  // Real-time readable (atomics only).
  std::int64_t lastReceiveNs() const noexcept { return last_receive_ns_.load(std::memory_order_relaxed); }
  /// When the receive thread last woke up (it polls at least every 50 ms): stale means the
  /// thread itself was starved, not that ftidd stopped publishing.
  std::int64_t lastPollNs() const noexcept { return last_poll_ns_.load(std::memory_order_relaxed); }
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
  std::vector<transport::Ipv4Net> allowed_;
  std::unique_ptr<RunStreamWriter> stream_;
  std::unique_ptr<Impl> impl_;
  mutable std::mutex mutex_;
  std::vector<CycleRecord> records_;
  std::atomic<bool> running_{false};
  std::thread thread_;
  std::atomic<std::int64_t> last_receive_ns_{0};
  std::atomic<std::int64_t> last_poll_ns_{0};
  bool have_cycle_ = false;         ///< receive thread only
  std::int64_t newest_cycle_ = 0;   ///< receive thread only
  std::atomic<std::int64_t> invalid_streak_{0};
  std::atomic<std::size_t> count_{0};
  std::atomic<std::size_t> dropped_{0};
};

/// Consistency of a recorded FTID_CYCLE stream with the controller's clock (docs/operations.md,
/// "Network and commands"). ftidd publishes one record per robot packet: cycle numbers increase by
/// one per record, robot times are whole controller periods apart. A second publisher on the
/// channel (a replayed or forged stream) shows up as records that share a cycle number or a robot
/// time with different content, as spacing that is not a whole number of periods, or as more
/// records than the controller can have produced.
struct CycleStreamReport {
  std::size_t received = 0;            ///< records in the window as received
  std::size_t unique = 0;              ///< after removing exact duplicates
  std::size_t exact_duplicates = 0;    ///< byte-for-byte repeats of a record (dropped)
  std::size_t conflicts = 0;           ///< same cycle number or robot time, different content
  std::size_t bad_spacing = 0;         ///< robot-time step not a whole number (>= 1) of periods
  std::size_t bad_sequence = 0;        ///< cycle number not increasing, or more cycles than periods
  std::size_t out_of_order = 0;        ///< arrived with a robot time below the previous one
  std::size_t expected = 0;            ///< periods spanned by the window (+1)
  std::size_t missing = 0;             ///< expected - unique (gaps), if positive
  double max_missing_fraction = 0.2;   ///< limit used by ok()
  /// True if the stream can be trusted for identification: no conflicts, spacing or sequence
  /// errors, not more records than periods and at most max_missing_fraction missing.
  bool ok() const noexcept;
  /// One line: counts, and what is wrong if !ok().
  std::string describe() const;
};

/// Checks the records with t_min <= robot_time <= t_max against the controller rate and returns the
/// verdict; *clean receives the records in robot-time order with exact duplicates removed.
CycleStreamReport checkCycleStream(const std::vector<CycleRecord>& records, double rate_hz,
                                   double t_min, double t_max,
                                   std::vector<CycleRecord>* clean = nullptr);

struct RecordsToLogReport {
  std::size_t converted = 0;
  std::size_t skipped_invalid = 0;        ///< robot state or sensor sample invalid/stale
  std::size_t skipped_non_monotonic = 0;  ///< robot time not strictly increasing
};

/// Converts cycle records to the CSV log format (docs/log-format.md): t = robot time [s],
/// q/qd/qdd from the robot state, the raw wrench, IMU and temperature from the sensor sample.
/// Records with an invalid robot state or sensor sample are dropped (never fitted as valid).
/// Only records with t_min <= robot_time <= t_max are kept.
logio::LogData recordsToLog(const std::vector<CycleRecord>& records, double t_min,
                            double t_max, const std::string& source, RecordsToLogReport* report = nullptr);

}  // namespace ftid::cell
