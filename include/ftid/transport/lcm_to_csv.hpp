#pragma once
// Conversion of ftidd's recorded cycle samples (an LCM log) to the CSV log format
// (ftid/logio/log.hpp, docs/log-format.md), so that recorded runs can be analysed with
// `ftid analyze` and identified with `ftid identify`.
#include <cstddef>
#include <string>

#include "ftid/logio/log.hpp"
#include "ftid/common/records.hpp"

namespace ftid::transport {

struct LcmToLogOptions {
  std::string channel = "FTID_CYCLE";  ///< channel carrying cycle_sample_t
  /// Keep cycles whose robot state or sensor sample was invalid/stale (default: drop them, since
  /// a stale reading must never be fitted as if it belonged to that robot state).
  bool keep_invalid = false;
};

struct LcmToLogReport {
  std::size_t events = 0;               ///< events in the file (all channels)
  std::size_t on_channel = 0;           ///< events on the requested channel
  std::size_t converted = 0;            ///< rows written
  std::size_t skipped_invalid = 0;      ///< robot or sensor invalid
  std::size_t skipped_non_monotonic = 0;///< robot_time not strictly increasing
  std::size_t skipped_non_finite = 0;   ///< NaN/inf in a value that would be written
  std::size_t decode_errors = 0;        ///< events on the channel that were not cycle_sample_t
};

/// Builds a measurement log from cycle records, one at a time (shared by lcmLogToLogData and
/// `ftid --identify`, which records the same records live): drops invalid (unless keep_invalid),
/// non-finite and non-monotonic records, counting each in the report.
class CycleLogBuilder {
 public:
  explicit CycleLogBuilder(std::string source, bool keep_invalid = false);
  /// Returns true if the record became a row.
  bool add(const CycleRecord& record);
  const LcmToLogReport& report() const { return report_; }
  LcmToLogReport& report() { return report_; }
  /// The log so far (has_imu / has_temp set when every row has them).
  logio::LogData finish() const;

 private:
  logio::LogData log_;
  bool keep_invalid_;
  bool all_imu_ = true;
  bool all_temp_ = true;
  double last_t_;
  LcmToLogReport report_;
};

/// Reads an LCM log and returns its cycle samples as a measurement log. t is the robot
/// controller timestamp [s]; the IMU/temperature columns are present when every converted
/// sample has them. Extra columns: `cycle`, `sensor_age_ms`, `fault_bits`.
/// Throws DataError naming the file if it cannot be read or holds no usable sample.
logio::LogData lcmLogToLogData(const std::string& lcm_log_path, const LcmToLogOptions& options,
                               LcmToLogReport* report = nullptr);

}  // namespace ftid::transport
