#pragma once
// The CSV log format (docs/log-format.md): one header row, one row per sample, SI units.
// Columns: t, q1..q6, qd1..qd6, qdd1..qdd6, fx, fy, fz, tx, ty, tz,
//          ax, ay, az, wx, wy, wz, alx, aly, alz, temp
// The IMU group (ax..alz) and temp may be absent; extra columns are kept by name, unused by default.
// Readers reject NaN/inf, non-monotonic t and wrong column counts with a DataError naming
// file, line and column.
#include <string>
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
};

enum class LogKind {
  kMeasurement,  ///< wrench columns required
  kTrajectory,   ///< only t, q, qd, qdd required (designed trajectories)
};

/// Reads a CSV log. Throws DataError("FILE:LINE:COLUMN: message") on any malformed input.
LogData readLog(const std::string& path, LogKind kind = LogKind::kMeasurement);

/// Writes a CSV log atomically (temporary file + rename). Writes the IMU and temp columns only if
/// the corresponding has_* flag is set, and the extra columns after them.
void writeLog(const std::string& path, const LogData& log);

}  // namespace ftid::logio
