#pragma once
// The cell's safety limits (issue 26): the floor, keep-out spheres, joint position, speed and
// acceleration limits live in the cell's configuration (config/cell_limits.yaml, installed
// root-owned as /etc/ftid/cell_limits.yaml beside ftidd.yaml), not in the trajectory file. A
// trajectory file's own constraints can only tighten them: whoever edits a trajectory cannot move
// the floor or widen a limit. `ftid check-trajectory` and `ftid --identify` check against the
// effective limits and say which file each came from.
#include <array>
#include <string>
#include <vector>

#include "ftid/trajectory/trajectory_io.hpp"

namespace ftid::trajectory {

struct CellLimits {
  std::string path;  ///< the file they came from
  JointVector position_lower = JointVector::Zero();  ///< [rad]
  JointVector position_upper = JointVector::Zero();  ///< [rad]
  JointVector velocity = JointVector::Zero();        ///< [rad/s]
  JointVector acceleration = JointVector::Zero();    ///< [rad/s^2]
  double floor_z_B = 0.0;                            ///< [m]
  std::vector<KeepOutSphere> keep_out;
};

/// Reads the cell's limits (YAML, a mapping `limits:` with position_lower, position_upper,
/// velocity, acceleration [6 each], floor_z and optionally keep_out [{name, center, radius}]).
/// Every key is required except keep_out; lower < upper, speeds and accelerations > 0. Throws
/// ConfigError naming the file, line and key.
CellLimits readCellLimits(const std::string& path);
CellLimits parseCellLimitsText(const std::string& text, const std::string& path);

/// /etc/ftid/cell_limits.yaml if it exists, else the shipped config/cell_limits.yaml.
std::string defaultCellLimitsPath();

/// The installed, root-owned cell limits.
constexpr const char* kInstalledCellLimitsPath = "/etc/ftid/cell_limits.yaml";

/// The cell limits that apply, in order: the installed file (when it exists) always; `extra_path`
/// (`--cell FILE`, "" = none) on top of it, so it can only tighten the installed limits; neither:
/// the shipped config/cell_limits.yaml. Throws ConfigError naming a file that cannot be read.
std::vector<CellLimits> applicableCellLimits(const std::string& extra_path,
                                             const std::string& installed_path = kInstalledCellLimitsPath);

/// Where each effective limit came from (a file name), per joint where the limit is per joint.
struct LimitSources {
  std::array<std::string, kNumJoints> position_lower, position_upper, velocity, acceleration;
  std::string floor_z;
  std::vector<std::string> keep_out;  ///< per entry of the effective keep_out
};

/// The effective constraints: `traj` (from `traj_source`) tightened by the cell: per joint the
/// larger lower and the smaller upper position limit, the smaller speed and acceleration, the
/// higher floor, the union of the keep-out spheres; the tool spheres and sensor mount of `traj`.
/// A limit where the trajectory is tighter is the trajectory's (sources say so).
TrajectoryConstraints effectiveConstraints(const TrajectoryConstraints& traj, const std::string& traj_source,
                                           const CellLimits& cell, LimitSources* sources);

/// The same tightened by each of `cells` in turn (applicableCellLimits): every file only tightens.
TrajectoryConstraints effectiveConstraints(const TrajectoryConstraints& traj, const std::string& traj_source,
                                           const std::vector<CellLimits>& cells, LimitSources* sources);

/// One line per limit group: "floor_z 0 m (cell_limits.yaml)", "velocity [..] rad/s (j1-3 ...)".
std::string describeLimits(const TrajectoryConstraints& c, const LimitSources& sources);

}  // namespace ftid::trajectory
