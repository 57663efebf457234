#pragma once
// `ftid --identify`: the one-shot identification on a cell (docs/operations.md).
//
//   1. load the ftidd config (robot address, LCM URL and channels, parameter file, sensor mount);
//   2. check that ftidd is publishing synchronised cycle samples and the sensor is healthy, and
//      that the robot is ready (RTDE state: RUNNING, NORMAL);
//   3. ask for confirmation (unless assume_yes);
//   4. move slowly to the start pose and run the excitation trajectory on the robot clock
//      (motion::runOnRobot), while ftidd's cycle samples are recorded; the motion is aborted at
//      once if ftidd's stream stops (ftidd killed) or the sensor goes stale/invalid, on Ctrl-C, or
//      on any robot fault; the arm is left stopped;
//   5. save the recorded data (CSV log, always, also after a fault);
//   6. identify the model, with held-out residuals, and run the model-laboratory analysis
//      (which effect is missing, and the command that adds it);
//   7. write the parameter file atomically (previous version kept as .bak) with provenance, plus
//      the UR and ros2_control exports beside it, and ask ftidd to reload (LCM command, ack).
// Faults end with a clear message, the arm stopped, the previous parameters intact and the
// recorded data saved.
#include <atomic>
#include <functional>
#include <string>

#include "ftid/common/types.hpp"

namespace ftid::cell {

/// The shipped excitation trajectory `ftid --identify` uses without --trajectory, for the robot
/// of the config (the URDF's file name without .urdf, e.g. "ur10", "ur10e"):
/// `excitation_<robot>.yaml`, a 3 s trajectory designed for paper+rigid_body, or with `paper`
/// `excitation_<robot>_paper.yaml`, the paper's 10 s excitation. Found by the one default-file
/// lookup (ftid/common/default_files.hpp).
std::string defaultTrajectoryName(const std::string& urdf_path, bool paper);
/// The model `ftid --identify` fits by default (the one the default trajectory is designed for).
inline constexpr const char* kDefaultModel = "paper+rigid_body";

struct CellIdentifyOptions {
  std::string config_path = "/etc/ftid/ftidd.yaml";  ///< ftidd config (robot, LCM, parameters)
  std::string trajectory_path;  ///< traj.yaml; empty = the shipped default for the robot
  /// The cell's safety limits (trajectory::readCellLimits); empty = defaultCellLimitsPath().
  /// The trajectory's own constraints can only tighten them.
  std::string cell_limits_path;
  std::string model = kDefaultModel;  ///< model to identify (e.g. "paper")
  bool paper = false;           ///< without trajectory_path: the paper's 10 s trajectory
  std::string runs_dir;         ///< where recorded runs go; empty = <params dir>/runs
  /// empty = the config's parameters.path. Another file is refused (ConfigError) unless
  /// reload_daemon is false: ftidd loads only its configured file.
  std::string params_path;
  int script_port = 30003;      ///< URScript upload port
  int register_offset = 0;      ///< RTDE input register offset (0 or 24)
  bool assume_yes = false;      ///< skip the confirmation prompt
  bool reload_daemon = true;    ///< ask ftidd to reload the new parameters
  bool analyze = true;          ///< run the model-laboratory analysis
  int folds = 5;
  double ftidd_timeout_s = 0.25;      ///< motion aborts if no cycle sample arrives for this long
  int max_invalid_sensor_cycles = 5;  ///< consecutive invalid sensor samples that abort the motion
  double startup_wait_s = 5.0;        ///< wait for ftidd's first cycle samples
  bool require_realtime = false;
  const std::atomic<bool>* abort = nullptr;  ///< set by the caller on SIGINT
  std::function<bool(const std::string& question)> confirm;  ///< returns true to proceed
  std::function<void(const std::string& line)> print;        ///< normal output (stdout)
  /// Live progress while the robot moves: phase name, elapsed and total trajectory time [s].
  std::function<void(const std::string& phase, double elapsed_s, double total_s)> progress;
};

struct CellIdentifyResult {
  int exit_code = 1;               ///< 0 ok, 1 failure (message says why)
  std::string message;             ///< one-line summary
  std::string data_csv;            ///< recorded run (empty if nothing was recorded)
  std::string params_path;         ///< written parameter file (empty if none written)
  std::string analysis_json;       ///< lab analysis (empty if not run)
  Vec6 heldout_rms = Vec6::Zero(); ///< held-out residual per axis
  Vec6 noise_floor = Vec6::Zero();
  std::string suggested_effect;    ///< top significant missing effect, "" if none
  bool reloaded = false;
};

/// Never throws for run-time faults (they end in the result); throws ConfigError for a bad
/// config/trajectory before anything moves.
CellIdentifyResult runCellIdentify(const CellIdentifyOptions& options);

}  // namespace ftid::cell
