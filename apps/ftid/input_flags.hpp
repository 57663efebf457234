#pragma once
// The recording options shared by identify, analyze, compensate and convert (docs/log-format.md):
// --wrench-log, --wrench-time-offset, --qdd-source, --ur-payload, --joint-topic, --wrench-topic. Header-only (the CMake glob
// takes only cmd_*.cpp).
#include <cstddef>
#include <string>
#include <vector>

#include "cli_args.hpp"
#include "ftid/logio/input.hpp"

namespace ftid::cli {

/// Help text of the recording options (appended to each command's usage).
inline constexpr const char* kInputFlagsHelp =
    "  --wrench-log FILE the sensor's own recording (time column t/time/timestamp in seconds, wrench\n"
    "                    columns fx..tz or Fx..Tz, Mx..Mz, force_x..): aligned with the robot's by\n"
    "                    time over the span both cover (the faster stream interpolated at the slower\n"
    "                    one's instants); prints how many samples it used. Both on one clock: a\n"
    "                    residual offset is estimated by a model with sensor_delay (its delay)\n"
    "  --wrench-time-offset S  added to the wrench log's times first (a known clock offset) [s]\n"
    "  --qdd-source diff|target  UR recordings: joint accelerations from smoothed differences of\n"
    "                    actual_qd (default) or the controller's target_qdd_0..5\n"
    "  --ur-payload M,CX,CY,CZ  UR recordings with actual_TCP_force as the wrench: the payload\n"
    "                    configured on the controller (kg; centre of mass in the TCP frame, m),\n"
    "                    whose gravity the controller subtracted and ftid adds back (default 0)\n"
    "  --joint-topic T   ROS 2 bags (a rosbag2 directory, sqlite3 storage, given as the log): the\n"
    "                    sensor_msgs/JointState topic (default /joint_states; UR joint names)\n"
    "  --wrench-topic T  ROS 2 bags: the geometry_msgs/WrenchStamped topic (default: the only one)\n";

/// `usage` with its "%INPUT%" marker replaced by kInputFlagsHelp (each recording command's --help).
inline std::string withInputFlagsHelp(std::string usage) {
  const std::string marker = "%INPUT%";
  const auto at = usage.find(marker);
  if (at != std::string::npos) usage.replace(at, marker.size(), kInputFlagsHelp);
  return usage;
}

/// Help text of --max-rows for a command whose default is `default_rows`, which take about `memory`.
inline std::string maxRowsHelp(std::size_t default_rows, const std::string& memory) {
  return "  --max-rows N      at most N rows of an ftid log are held (default " + std::to_string(default_rows) +
         ", about " + memory + ";\n"
         "                    extra columns lower N by their size): a longer log is read in one pass,\n"
         "                    every row checked, and thinned in blocks of consecutive rows, the larger of\n"
         "                    the still and the moving rows first (a short motion among long rests stays\n"
         "                    whole); a warning says how (docs/log-format.md \"Limits\"). 0: the whole\n"
         "                    log (refused beyond FTID_MAX_LOG_ROWS rows, 2,000,000 by default)\n";
}

/// `usage` with its "%MAX_ROWS%" marker replaced by maxRowsHelp(default_rows, memory).
inline std::string withMaxRowsHelp(std::string usage, std::size_t default_rows, const std::string& memory) {
  const std::string marker = "%MAX_ROWS%";
  const auto at = usage.find(marker);
  if (at != std::string::npos) usage.replace(at, marker.size(), maxRowsHelp(default_rows, memory));
  return usage;
}

/// --max-rows into `rows` (logio::InputOptions::max_rows).
inline void addMaxRows(CLI::App& app, std::size_t& rows) {
  app.add_option("--max-rows", rows)->transform(integer(0, 1000000000));
}

struct InputFlags {
  std::string wrench_log;
  double wrench_time_offset_s = 0.0;
  std::string qdd_source;
  std::vector<double> ur_payload;
  std::string joint_topic = "/joint_states";
  std::string wrench_topic;
};

inline void addInputFlags(CLI::App& app, InputFlags& flags) {
  app.add_option("--wrench-log", flags.wrench_log);
  app.add_option("--wrench-time-offset", flags.wrench_time_offset_s)->transform(real({-1e9, 1e9}));
  app.add_option("--qdd-source", flags.qdd_source)->transform(oneOf({"diff", "target"}));
  addReals(app, "--ur-payload", flags.ur_payload, 4, {-1e3, 1e3});
  app.add_option("--joint-topic", flags.joint_topic);
  app.add_option("--wrench-topic", flags.wrench_topic);
}

inline void applyInputFlags(const InputFlags& flags, logio::InputOptions& input) {
  input.wrench_log = flags.wrench_log;
  input.wrench_time_offset_s = flags.wrench_time_offset_s;
  input.qdd_source = logio::parseQddSource(flags.qdd_source);
  input.joint_topic = flags.joint_topic;
  input.wrench_topic = flags.wrench_topic;
  if (flags.ur_payload.size() == 4) {
    if (!(flags.ur_payload[0] >= 0.0)) throw UsageError("--ur-payload: the mass must not be negative");
    input.ur_payload_mass_kg = flags.ur_payload[0];
    input.ur_payload_com_tcp_m = Vec3(flags.ur_payload[1], flags.ur_payload[2], flags.ur_payload[3]);
  }
}

}  // namespace ftid::cli
