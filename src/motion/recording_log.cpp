#include "ftid/motion/recording_log.hpp"

#include <string>

namespace ftid::motion {

logio::LogData recordingToLog(const std::vector<RecordedTick>& recording) {
  logio::LogData log;
  log.has_wrench = false;
  log.has_imu = false;
  log.has_temp = false;
  log.extra_names = {"robot_timestamp", "t_traj", "phase"};
  for (int i = 1; i <= 6; ++i) log.extra_names.push_back("q_cmd" + std::to_string(i));
  for (int i = 1; i <= 6; ++i) log.extra_names.push_back("target_q" + std::to_string(i));
  log.extra_names.insert(log.extra_names.end(), {"robot_mode", "safety_mode", "runtime_state"});
  log.extra_columns.assign(log.extra_names.size(), {});
  if (recording.empty()) return log;
  const double t0 = recording.front().state.timestamp;
  JointVector last_cmd = recording.front().state.q;
  for (const auto& r : recording) {
    logio::LogSample s;
    s.t = r.state.timestamp - t0;
    s.q = r.state.q;
    s.qd = r.state.qd;
    s.qdd = r.state.target_qdd;
    log.samples.push_back(s);
    if (r.q_command.allFinite()) last_cmd = r.q_command;
    std::size_t k = 0;
    log.extra_columns[k++].push_back(r.state.timestamp);
    log.extra_columns[k++].push_back(r.t_traj);
    log.extra_columns[k++].push_back(static_cast<double>(r.phase));
    for (int i = 0; i < 6; ++i) log.extra_columns[k++].push_back(last_cmd[i]);
    for (int i = 0; i < 6; ++i) log.extra_columns[k++].push_back(r.state.target_q[i]);
    log.extra_columns[k++].push_back(r.state.robot_mode);
    log.extra_columns[k++].push_back(r.state.safety_mode);
    log.extra_columns[k++].push_back(r.state.runtime_state);
  }
  return log;
}

}  // namespace ftid::motion
