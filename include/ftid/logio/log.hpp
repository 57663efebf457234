#pragma once
// The CSV log format (docs/log-format.md): one header row, one row per sample, SI units.
// Columns: t, q1..q6, qd1..qd6, qdd1..qdd6, fx, fy, fz, tx, ty, tz,
//          ax, ay, az, wx, wy, wz, alx, aly, alz, temp
// The IMU group (ax..alz) and temp may be absent; extra columns are kept by name, unused by default.
// Readers reject NaN/inf, non-monotonic t and wrong column counts with a DataError naming
// file, line and column.
#include <array>
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "ftid/common/types.hpp"

namespace ftid::logio {

struct LogSample {
  double t = 0.0;                          ///< [s]
  JointVector q = JointVector::Zero();     ///< joint angles [rad] (controller actual_q)
  JointVector qd = JointVector::Zero();    ///< [rad/s]
  JointVector qdd = JointVector::Zero();   ///< [rad/s^2]
  Wrench wrench_S = Wrench::Zero();        ///< raw sensor reading in S [N, Nm]
  Vec3 acc_S = Vec3::Zero();               ///< IMU specific force R_WS^T (a_W - g_W) [m/s^2]
  Vec3 w_S = Vec3::Zero();                 ///< IMU angular velocity [rad/s]
  Vec3 alpha_S = Vec3::Zero();             ///< IMU angular acceleration [rad/s^2]
  double temp_degC = 0.0;                  ///< sensor temperature [degC]
};

struct LogData {
  std::string source;  ///< file path (for messages)
  std::vector<LogSample> samples;
  bool has_wrench = true;
  /// false: a pose log (docs/log-format.md "Pose logs"): no q/qd/qdd columns (zero in the
  /// samples); the pose columns qx..qw or rx..rz are among the extra columns.
  bool has_joints = true;
  bool has_imu = false;
  bool has_temp = false;
  std::vector<std::string> extra_names;             ///< extra columns, in file order
  std::vector<std::vector<double>> extra_columns;   ///< extra_columns[k][i]: column k, sample i

  /// Index of an extra column by name, or -1.
  int extraIndex(const std::string& name) const;
  /// Keeps the samples i with keep[i] != 0 (one entry per sample), in order, with their extra
  /// values.
  void keepRows(const std::vector<char>& keep);
};

enum class LogKind {
  kMeasurement,  ///< wrench columns required
  kTrajectory,   ///< only t, q, qd, qdd required (designed trajectories)
};

/// Limits on what the reader accepts from an untrusted file (docs/log-format.md).
inline constexpr std::size_t kMaxColumns = 1024;         ///< header columns
inline constexpr std::size_t kMaxHeaderBytes = 65536;    ///< header row length
/// Data rows a log may have unless FTID_MAX_LOG_ROWS says otherwise (docs/log-format.md
/// "Limits"): identification holds about 2 KB per row in memory (the text, the samples, the
/// contexts, the stacked regressor), so 2 M rows need about 4 GB.
inline constexpr std::size_t kDefaultMaxLogRows = 2000000;
/// Measured working memory per row of `ftid identify` (200,000 rows: 382 MB peak).
inline constexpr std::size_t kWorkingBytesPerRow = 2000;

/// The row limit: FTID_MAX_LOG_ROWS (a positive integer) or kDefaultMaxLogRows. Throws
/// ConfigError naming the variable when it is set to anything else.
std::size_t maxLogRows();

/// Reads a log-like text file (readInputFile: a regular file of at most kMaxLogBytes) and refuses
/// it at once, before any parsing allocates, when its header row is longer than kMaxHeaderBytes
/// or it has more lines than maxLogRows() allows (the message gives the rows, the memory they
/// would need and how to proceed). Throws DataError naming the file.
std::string readLogText(const std::string& path);

/// Rated range of the shipped sensor (config/ftsensor.dbc): Fx, Fy, Fz [N], Tx, Ty, Tz [Nm].
inline constexpr std::array<double, 6> kDefaultRatedWrench_S = {300.0, 300.0, 500.0, 25.0, 25.0, 25.0};

/// Largest plausible |value| per column; a value beyond it is a DataError naming line and column.
struct LogReadOptions {
  double max_abs_t_s = 1e12;
  double max_abs_q_rad = 4.0 * 3.14159265358979323846;  ///< joint angles: +-4 pi
  double max_abs_qd_rad_s = 1e3;
  double max_abs_qdd_rad_s2 = 1e6;
  /// 100x the sensor's rated range (withRatedWrench; default: the shipped DBC's range).
  std::array<double, 6> max_abs_wrench_S = {3e4, 3e4, 5e4, 2.5e3, 2.5e3, 2.5e3};
  double max_abs_acc_m_s2 = 1e4;
  double max_abs_w_rad_s = 1e3;
  double max_abs_alpha_rad_s2 = 1e6;
  double max_abs_temp_degC = 1e3;

  /// Options with the wrench limits set to 100x `rated_S` (e.g. the [min|max] ranges of a DBC).
  static LogReadOptions withRatedWrench(const std::array<double, 6>& rated_S) {
    LogReadOptions o;
    for (std::size_t a = 0; a < 6; ++a) o.max_abs_wrench_S[a] = 100.0 * rated_S[a];
    return o;
  }
};

/// Reads a CSV log: a regular file (FIFOs, directories and devices are refused, see
/// ftid/fileio/input_file.hpp), at most kMaxColumns columns with distinct names, every value
/// finite and within `options`. Throws DataError("FILE:LINE:COLUMN: message") on any malformed input.
LogData readLog(const std::string& path, LogKind kind = LogKind::kMeasurement,
                const LogReadOptions& options = {});

/// The same checks on a log already in memory (`path` names it in messages; the fuzz target's entry).
LogData parseLogText(std::string_view text, const std::string& path, LogKind kind = LogKind::kMeasurement,
                     const LogReadOptions& options = {});

/// Memory an extra column costs per row held [bytes]: its value in the log and in the contexts.
inline constexpr std::size_t kExtraColumnBytesPerRow = 16;
/// A row is "holding still" when every |qd| is below this [rad/s] (readLogThinned's classes).
inline constexpr double kStillSpeedRadS = 1e-3;

/// The rows a log may hold within `max_rows` (each kWorkingBytesPerRow) when it has
/// `extra_columns` extra columns: max_rows * 2000 / (2000 + 16 * extra_columns), at least 2 (the
/// first row of each class, which the thinning always keeps).
std::size_t rowBudget(std::size_t max_rows, std::size_t extra_columns);
/// Rows per block the thinning keeps or leaves out together: budget_rows / 16 within [1, 256].
std::size_t thinBlockRows(std::size_t budget_rows);

/// A log read in one pass within a row budget (readLogThinned).
struct ThinnedLog {
  LogData log;                     ///< the rows kept
  std::size_t rows = 0;            ///< data rows in the file (every one checked)
  std::size_t budget_rows = 0;     ///< rowBudget(max_rows, extra columns)
  std::size_t block_rows = 0;      ///< thinBlockRows(budget_rows)
  std::size_t still_rows = 0;      ///< rows holding still (every |qd| < kStillSpeedRadS)
  std::size_t moving_rows = 0;
  std::size_t still_stride = 1;    ///< every still_stride-th block of still rows is kept
  std::size_t moving_stride = 1;   ///< every moving_stride-th block of moving rows is kept
  bool thinned() const { return log.samples.size() < rows; }
};

/// Reads a CSV log of at most kMaxStreamedLogBytes in pieces, with readLog's checks on every
/// row, holding at most rowBudget(max_rows, extras) rows: the rows holding still and the moving
/// rows are each cut into blocks of thinBlockRows rows, and each class keeps every stride-th of
/// its blocks, the stride (a power of two) doubled for the class holding more rows whenever the
/// budget is passed (a short motion among long rests stays whole). Within the budget the rows
/// equal readLog's; unlike readLog, any line longer than kMaxLineBytes (file_lines.hpp, 1 MiB) is
/// refused and FTID_MAX_LOG_ROWS plays no part. A pose log (no joint columns) over the budget is
/// refused with the rows it has (its poses are differenced, so rows cannot be left out). Throws
/// DataError naming file and line.
ThinnedLog readLogThinned(const std::string& path, LogKind kind, const LogReadOptions& options, std::size_t max_rows);

/// True if the first row of `path` that is neither blank nor a comment is a UR recording's header.
bool isUrRecordFile(const std::string& path);

/// Writes a CSV log atomically (temporary file + rename). Writes the IMU and temp columns only if
/// the corresponding has_* flag is set, and the extra columns after them.
void writeLog(const std::string& path, const LogData& log);

}  // namespace ftid::logio
