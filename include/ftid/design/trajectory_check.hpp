#pragma once
// Independent verification of an excitation trajectory (used by `ftid check-trajectory` and by the
// designer after NLopt returns). It samples the trajectory densely with FourierTrajectory::evaluate
// and places the tool with RobotKinematics::computeFlangePose and the sensor mount, i.e. through a
// different code path than the optimiser's sampled basis and sensor-motion contexts.
#include <string>
#include <vector>

#include "ftid/model/kinematics.hpp"
#include "ftid/trajectory/fourier_trajectory.hpp"
#include "ftid/trajectory/trajectory_io.hpp"

namespace ftid::design {

/// The worst case of one constraint over the trajectory. margin >= 0 means satisfied.
struct ConstraintMargin {
  std::string
      name;  ///< e.g. "joint 5 velocity", "tool[0] above floor", "tool[0] outside robot_base"
  std::string unit;     ///< "rad", "rad/s", "rad/s^2", "m"
  double margin = 0.0;  ///< limit minus worst value (positive: inside)
  double worst = 0.0;   ///< the worst value reached
  double limit = 0.0;
  double t = 0.0;  ///< time of the worst value [s]
};

struct CheckReport {
  std::vector<ConstraintMargin> margins;
  double rest_error = 0.0;  ///< max |q(0)-q0|, |q(T)-q0|, |qd|, |qdd| at both ends
  bool whole_periods = true;
  bool finite = true;
  int samples = 0;
  double dt = 0.0;

  bool restToRest() const { return whole_periods && rest_error <= 1e-9; }
  bool ok() const;
  /// Violated constraints (margin < 0), one line each.
  std::vector<std::string> violations() const;
  /// Table of all margins, one line each (for printing).
  std::string table() const;
};

/// Checks joint position, velocity and acceleration limits, the floor plane and the keep-out
/// spheres (for every tool sphere), rest-to-rest and finiteness on samples every dt seconds plus
/// both ends. The kinematics' sensor mount is replaced by the constraints' mount (copy).
CheckReport checkTrajectory(const trajectory::FourierTrajectory& trajectory,
                            const model::RobotKinematics& kinematics,
                            const trajectory::TrajectoryConstraints& constraints, double dt = 1e-3);

/// Checks the exact joint targets a motion will stream (issue 14: run before any motion by
/// `ftid --identify` and `ftid run-trajectory`, whatever --yes says):
///   - every sample (approach and trajectory): finite, every tool sphere above the floor and
///     clear of every keep-out sphere;
///   - trajectory samples (t_traj[k], q_traj[k]): inside the designed joint ranges, and the
///     finite-difference velocity and acceleration between consecutive samples within the designed
///     limits (a difference quotient equals the derivative somewhere in between, so a trajectory
///     that passes checkTrajectory passes this too).
/// The approach (from the robot's current pose, which may lie outside the designed ranges) is held
/// to the floor and keep-out only. Returns one line per violated constraint, naming the first
/// offending sample, its time and the values; empty if all hold.
std::vector<std::string> checkMotionSamples(double period, const std::vector<JointVector>& approach,
                                            const std::vector<double>& t_traj,
                                            const std::vector<JointVector>& q_traj,
                                            const model::RobotKinematics& kinematics,
                                            const trajectory::TrajectoryConstraints& constraints);

}  // namespace ftid::design
