#pragma once
// Every recording ftid reads, as one native log (docs/log-format.md): ftid's own CSV log, UR's
// RTDE recordings (record.py, ur_rtde's startFileRecording), and a robot recording paired with
// the sensor's own recording (`--wrench-log`), aligned by time. The readers validate everything
// (files are untrusted) and say what they did in InputLog::notes.
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "ftid/common/types.hpp"
#include "ftid/logio/log.hpp"

namespace ftid::logio {

struct Table;

/// Where a UR recording's joint accelerations come from (`--qdd-source`).
enum class QddSource {
  kDifferences,  ///< smoothed differences of actual_qd (default; no UR controller measures qdd)
  kTarget,       ///< the controller's target_qdd_0..5 (the commanded acceleration)
};

/// Parses `--qdd-source diff|target` (ConfigError naming the option otherwise).
QddSource parseQddSource(const std::string& text);

struct InputOptions {
  /// The sensor's own recording (`--wrench-log`; "" = the wrench is in the main file).
  std::string wrench_log{};
  /// Added to the wrench log's times before the alignment [s] (`--wrench-time-offset`): a known
  /// clock offset between the two recorders.
  double wrench_time_offset_s = 0.0;
  QddSource qdd_source = QddSource::kDifferences;
  /// Half-width [samples] of the local least-squares slopes that differentiate joint velocities.
  int derivative_half_window = 3;
  /// The payload configured on the UR controller, which it subtracts from actual_TCP_force
  /// before reporting it (`--ur-payload M,CX,CY,CZ`; mass [kg], centre of mass in the TCP frame
  /// [m]); its gravity is added back so ftid sees the whole tool. Zero by default.
  double ur_payload_mass_kg = 0.0;
  Vec3 ur_payload_com_tcp_m = Vec3::Zero();
  /// Gravity the UR controller compensates the configured payload with, in the base [m/s^2].
  Vec3 ur_gravity_B = Vec3(0.0, 0.0, -9.80665);
  /// ROS 2 bags: the sensor_msgs/JointState topic (`--joint-topic`) and the
  /// geometry_msgs/WrenchStamped topic (`--wrench-topic`; "" = the bag's only one).
  std::string joint_topic = "/joint_states";
  std::string wrench_topic{};
  LogReadOptions read{};
  /// An ftid log's rows held in memory (`--max-rows`; readLogThinned; docs/log-format.md
  /// "Limits"): a longer log is read in one pass and thinned to this budget. 0: read whole (up to
  /// maxLogRows(), refused beyond). UR recordings, bags and --wrench-log pairs are read whole.
  std::size_t max_rows = 0;
};

/// One recording (or a pair of them) read as a native log.
struct InputLog {
  LogData log;
  std::string format;            ///< what was read, e.g. "UR RTDE recording (record.py, space-separated)"
  bool wrench_in_base = false;   ///< the wrench columns are in base axes (UR actual_TCP_force)
  std::vector<std::string> notes;  ///< what the reader did: rows dropped, alignment, sources
  /// The note saying how a log beyond InputOptions::max_rows was thinned ("" if it was not; also
  /// in `notes`), for the result's warnings.
  std::string thinned_note;
};

/// Reads `path` in whichever supported format it is (recognised from its header) and, with
/// `options.wrench_log`, pairs it with the sensor's recording. Throws DataError naming the file,
/// line and column on any malformed input, and a DataError naming the fix when the wrench is
/// missing (a UR recording without actual_TCP_force needs `--wrench-log`).
InputLog readInput(const std::string& path, const InputOptions& options = {});

// ---- the parts (each tested on its own) ------------------------------------------------------

/// True if `path` is a directory (a rosbag2 is one: metadata.yaml and its storage files).
bool isDirectory(const std::string& path);

/// A rosbag2 directory (sqlite3 storage) as a native log: the joint topic's JointState (UR joint
/// names, any order and prefix; velocities differenced if absent, accelerations always) and,
/// unless options.wrench_log is given, the wrench topic's WrenchStamped, aligned as alignWrench.
/// Times are the messages' header stamps (the bag's receive times for a topic whose stamps are
/// zero). Every byte is validated (cdr.hpp); errors name the bag file, topic and message.
InputLog readRosbag2(const std::string& dir, const InputOptions& options);

/// The robot's part of a recording: drops the stair steps (stairSteps; moving from the recorded
/// velocities if `has_qd`), then fills qdd (and qd if `has_qd` is false) from smoothed differences; notes what
/// it did. `what` names the state in the notes ("JointState messages").
void differenceJointLog(LogData& log, bool has_qd, int half_window, const std::string& what,
                        std::vector<std::string>& notes);

/// True if a header row is a UR RTDE recording's (has `timestamp` and `actual_q_0` or
/// `actual_TCP_pose_0`; space- or comma-separated).
bool isUrRecordHeader(std::string_view header);

/// A UR recording (record.py or ur_rtde's startFileRecording) as a native log: joint log from
/// actual_q/actual_qd (qdd per options.qdd_source), else a pose log from actual_TCP_pose (TCP =
/// S); the wrench from actual_TCP_force (base axes, moments about the TCP; wrench_in_base set)
/// plus the configured payload's gravity; other columns kept as extra columns. Stair steps
/// (stairSteps: the joint state and pose repeat the previous row's exactly while actual_qd is
/// non-zero) and exact duplicate rows are dropped before differencing (noted).
InputLog urRecordToLog(const Table& table, const InputOptions& options);

/// A sensor's own recording: a time column (`t`, `time`, `timestamp`, any case) and the six
/// wrench columns in ftid's or common spellings (columnAlias). Other columns are ignored.
LogData wrenchLogFromTable(const Table& table, const LogReadOptions& read = {});

/// Whether a wrench log's reader uses the column `name` (time, wrench, or a unit it refuses):
/// the column filter that lets other columns hold anything.
bool wrenchLogUsesColumn(const std::string& name);

/// The robot log with the wrench of `wrench` (times + offset_s) aligned to it: over the span
/// both cover only, the faster stream is interpolated linearly at the slower one's instants (a
/// pose log always keeps the robot's instants). Appends what it did to `notes`.
LogData alignWrench(const LogData& robot, const LogData& wrench, double offset_s, std::vector<std::string>& notes);

/// Smoothed derivative: at each sample the least-squares slope of y over the samples within
/// +-h of it (fewer at the ends). Centred, so without lag on a uniform grid; the gain at
/// frequency f and sample period dt is sum_k k sin(2 pi f k dt) / (2 pi f dt sum_k k^2)
/// (docs/log-format.md "UR recordings").
std::vector<JointVector> smoothedDerivative(const std::vector<double>& t, const std::vector<JointVector>& y, int h);

/// Longest run of repeated rows taken as stair steps when no velocity says whether the robot
/// moves (a recorder up to 10x faster than the robot's state updates); longer runs are rest.
inline constexpr std::size_t kMaxStairRun = 9;

/// Which rows are stair steps: `same[i]` says row i's state equals row i-1's exactly (same[0]
/// is false); `moving[i]` is 1 if the row's recorded velocity is non-zero (a repeat while moving
/// cannot be real), 0 if it is zero (at rest: repeats are real readings, kept), -1 if unknown (no
/// velocity: runs of at most kMaxStairRun repeats are stair steps, longer ones rest).
std::vector<bool> stairSteps(const std::vector<bool>& same, const std::vector<int>& moving);

/// Drops the stair steps (stairSteps, velocity unknown) of a pose log without kin_* motion
/// columns: rows whose pose columns repeat the previous row's exactly, in runs of at most
/// kMaxStairRun; returns how many were dropped.
std::size_t dropRepeatedPoses(LogData& log);

/// The ftid column a header name means, if it is a known alias or differs only in case, spaces,
/// '_' or a unit suffix ("Fx" -> "fx", "force_x" -> "fx", "Torque Z [Nm]" -> "tz",
/// "timestamp" -> "t", "actual_q_0" -> "q1"); "" if none. A unit suffix must be the SI unit ftid
/// reads (s; N; Nm, N·m, N-m, N*m; rad, rad/s, rad/s^2): any other (`Time [ms]`, `Fx [lbf]`) throws
/// a DataError naming the column and the unit.
std::string columnAlias(std::string_view name);

/// For an error about missing columns: " (the header has 'Fx': rename it to 'fx'; ...)" naming
/// each present column that would supply a missing one, or "" if there is none.
std::string missingColumnHint(const std::vector<std::string>& missing, const std::vector<std::string>& present);

}  // namespace ftid::logio
