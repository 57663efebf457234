#pragma once
// Converts a motion recording into the CSV log format (ftid/logio/log.hpp, docs/log-format.md).
// Joint columns: t = robot timestamp minus the first recorded timestamp [s], q = actual_q,
// qd = actual_qd, qdd = target_qdd (the controller reports no measured acceleration).
// Extra columns: robot_timestamp, t_traj (trajectory time, -1 outside the excitation), phase
// (0 approach, 1 settle, 2 excite, 3 finish, 4 stopping), q_cmd1..6 (target sent; NaN-free: the
// previous command is repeated when none was sent), target_q1..6, robot_mode, safety_mode,
// runtime_state. No wrench columns (has_wrench = false).
#include <vector>

#include "ftid/logio/log.hpp"
#include "ftid/motion/motion_runner.hpp"

namespace ftid::motion {

logio::LogData recordingToLog(const std::vector<RecordedTick>& recording);

}  // namespace ftid::motion
