#pragma once
// Building the per-sample SampleContext (ftid/effects/effect.hpp) of a whole log from the robot
// kinematics, each through the one sample builder (ftid/samples/sample_builder.hpp) that the
// daemon's cycle also uses. Frames and units: docs/conventions.md.
//
//   R_BS, p_BS_B, w_S, alpha_S, a_S  = RobotKinematics::computeSensorMotion(q, qd, qdd)
//   g_S                              = R_BS^T g_B(U, V)          (for the tilt in the options)
//   wrench_S, IMU columns, temp      = copied from the log
//   t                                = log t minus the first sample's t
//   extra, extra_names               = pointers to this sample's extra columns (row-major copy)
//                                      and to the set's column names (generic effects such as
//                                      poly(<column>,n) read them)
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "ftid/effects/effect.hpp"
#include "ftid/logio/input.hpp"

namespace ftid::logio {
struct LogData;
}
namespace ftid::model {
class RobotKinematics;
}

namespace ftid::samples {

using effects::SampleContext;

struct ContextOptions {
  Mat3 R_FS = Mat3::Identity();   ///< sensor mount X_FS (orientation of S in the flange F)
  Vec3 p_FS_F = Vec3::Zero();     ///< sensor mount (position of the S origin in F) [m]
  double tilt_u_rad = 0.0;        ///< tilt used to fill g_S (the fitter recomputes g_S itself)
  double tilt_v_rad = 0.0;
  /// The frame of the log's wrench columns: false = S (the sensor's own frame), true = B (the
  /// reading rotated into the robot base, moments still about the S origin):
  /// wrench_S = [R_BS^T f_B; R_BS^T t_B] (`--wrench-frame base`).
  bool wrench_in_base = false;
  /// Pose logs without motion columns: half-width [samples] of the local least-squares windows
  /// that differentiate the pose (smoothed finite differences).
  int derivative_half_window = 3;
  /// The parameter set's time origin [s, Unix time, UTC] (ParameterSet::time_origin_unix_s):
  /// for a log with a `host_time` column, SampleContext::t_model = host_time - this. NaN (no
  /// origin): the log's first host_time. Ignored for logs without `host_time`.
  double time_origin_unix_s = std::numeric_limits<double>::quiet_NaN();
  /// How loadLogContexts reads the recording (logio::readInput): a UR recording's acceleration
  /// source, the sensor's own recording (`--wrench-log`) and its clock offset, the UR payload.
  /// A UR recording's actual_TCP_force sets wrench_in_base.
  logio::InputOptions input{};
  /// loadLogContexts: drop the rows that only hold the previous row's reading (held_readings.hpp);
  /// identification and the laboratory set it, compensation of a log keeps every row.
  bool drop_held_readings = false;
};

/// The log column with the host's receive time of each robot state [s, Unix time, UTC]
/// (`ftid lcm-to-csv`, `ftid --identify`; docs/log-format.md): the clock of the model's time.
inline constexpr const char* kHostTimeColumn = "host_time";

/// Parses `--wrench-frame sensor|base` (throws ConfigError naming the option otherwise).
bool parseWrenchFrame(const std::string& text);

/// The contexts of one log. Owns the row-major copy of the extra columns that
/// SampleContext::extra points into and the names SampleContext::extra_names points to; copying
/// and moving re-point the samples to the new owner.
struct ContextSet {
  std::string source;                    ///< log file (for messages)
  double t_origin = 0.0;                 ///< log t of the first sample (SampleContext::t is relative)
  /// The time origin of SampleContext::t_model [s, Unix time]: ContextOptions::time_origin_unix_s
  /// or the first sample's host_time; NaN for a log without `host_time` (t_model = t).
  double time_origin_unix_s = std::numeric_limits<double>::quiet_NaN();
  std::vector<SampleContext> samples;
  std::vector<std::string> extra_names;  ///< names of the extra columns, in order
  std::vector<double> extra_rows;        ///< extra_rows[i * extra_names.size() + k]
  bool has_imu = false;
  bool has_temp = false;
  /// Rows loadLogContexts dropped as held readings (ContextOptions::drop_held_readings) and its
  /// line for the user (describeHeldReadings; "" when none).
  int held_rows = 0;
  std::string held_note;
  /// How readInput thinned a log beyond ContextOptions::input.max_rows (logio::InputLog::
  /// thinned_note; "" when every row is used).
  std::string thinned_note;

  ContextSet() = default;
  ContextSet(const ContextSet& other);
  ContextSet& operator=(const ContextSet& other);
  ContextSet(ContextSet&& other) noexcept;
  ContextSet& operator=(ContextSet&& other) noexcept;
  ~ContextSet() = default;

  /// Index of an extra column by name, or -1.
  int extraIndex(const std::string& name) const;
  std::size_t size() const { return samples.size(); }
  /// Points every SampleContext::extra at its row of extra_rows and extra_names at extra_names
  /// (after editing either; nullptr when there are no extra columns).
  void repoint();
  /// Keeps the samples i with keep[i] != 0 (keep: one entry per sample), in order, with their
  /// extra rows; repoints. Used for the held readings (loadLogContexts) and a time window.
  void keepRows(const std::vector<char>& keep);
};

/// Builds contexts for every sample of the log. Throws DataError (naming the log) if the log has
/// no wrench columns or no samples.
///
/// Pose logs (docs/log-format.md; log.has_joints false) give the pose of S in B instead of joint
/// angles: R_BS from qx,qy,qz,qw (|q| within 1e-3 of 1, then normalised) or from
/// rx,ry,rz (rotation vector, UR actual_TCP_pose), p_BS_B from px,py,pz (optional, else 0).
/// w_S, alpha_S, a_S come from the columns kin_wx..kin_wz, kin_alx..kin_alz, kin_ax..kin_az if
/// present, else from smoothed finite differences of the pose (local least squares over
/// +-derivative_half_window samples; a_S = 0 without a position). q and qd are zero and
/// has_joints is false in every context.
ContextSet buildContexts(const logio::LogData& log, const model::RobotKinematics& kinematics,
                         const ContextOptions& options = {});

/// Reads the recording (logio::readInput with options.input: an ftid log, a UR recording, either
/// with a sensor's own recording) and the robot (`robot_urdf`, "" = defaultRobotUrdf()) and builds
/// the contexts; `progress` (optional) gets a line for each step and each of the reader's notes
/// (rows dropped, alignment), and held_note. With options.drop_held_readings the held rows
/// (findHeldReadings) are dropped after the kinematics are built on every row. Throws as readInput, the URDF
/// loader and buildContexts do.
ContextSet loadLogContexts(const std::string& log_path, const std::string& robot_urdf,
                           const ContextOptions& options = {},
                           const std::function<void(const std::string& line)>& progress = {});

/// Sets g_S = R_BS^T g_B(U, V) in every context.
void setTilt(std::vector<SampleContext>& contexts, double tilt_u_rad, double tilt_v_rad);

}  // namespace ftid::samples
