#pragma once
// Excitation trajectory files (docs/design.md):
//   traj.yaml  the Fourier coefficients and everything needed to reproduce and re-check the
//              trajectory: start pose, base frequency, harmonics, duration, excited joints, servo
//              rate, the constraints it was designed under, the design settings (model,
//              objective, seed, NLopt algorithms and budgets) and the achieved metrics.
//   traj.csv   the trajectory sampled at the servo rate with the log format's columns
//              t, q1..q6, qd1..qd6, qdd1..qdd6 (docs/log-format.md, LogKind::kTrajectory).
// Frames and units: docs/conventions.md. Writers are atomic (temporary file + rename); readers
// throw ConfigError naming the file and the key.
#include <array>
#include <map>
#include <string>
#include <vector>

#include "ftid/common/types.hpp"
#include "ftid/trajectory/fourier_trajectory.hpp"

namespace ftid::trajectory {

/// A sphere the tool must stay out of, fixed in the robot base frame B.
struct KeepOutSphere {
  std::string name;              ///< e.g. "robot_base" (for messages)
  Vec3 center_B = Vec3::Zero();  ///< [m]
  double radius = 0.0;           ///< [m]
};

/// A sphere fixed in the sensor frame S that encloses (part of) the tool/payload.
struct ToolSphere {
  Vec3 center_S = Vec3::Zero();  ///< [m]
  double radius = 0.0;           ///< [m]
};

/// The limits a trajectory must respect, checked on the real (densely sampled) trajectory.
struct TrajectoryConstraints {
  JointVector position_lower = JointVector::Constant(-6.283185307179586);  ///< [rad]
  JointVector position_upper = JointVector::Constant(6.283185307179586);   ///< [rad]
  JointVector velocity = JointVector::Constant(3.14);                      ///< [rad/s]
  JointVector acceleration = JointVector::Constant(10.0);                  ///< [rad/s^2]
  double floor_z_B = -1e9;  ///< tool spheres must stay above the plane z_B = floor_z_B [m]
  std::vector<KeepOutSphere> keep_out;
  std::vector<ToolSphere> tool;
  Mat3 R_FS = Mat3::Identity();  ///< sensor mount (docs/conventions.md), used for the tool pose
  Vec3 p_FS_F = Vec3::Zero();
};

/// One Fourier excitation trajectory (paper Eq. 47-49 about q0) plus its provenance.
struct TrajectoryFile {
  // --- the trajectory itself
  JointVector q0 = JointVector::Zero();
  double base_frequency_hz = 0.1;
  int harmonics = 5;
  double duration_s = 10.0;
  std::vector<int> joints;  ///< excited joints, 1-based (UR order), e.g. {4, 5, 6}
  std::array<std::array<double, FourierTrajectory::kMaxHarmonics>, kNumJoints> a{};  ///< [rad/s]
  std::array<std::array<double, FourierTrajectory::kMaxHarmonics>, kNumJoints> b{};  ///< [rad/s]
  double servo_rate_hz = 125.0;  ///< rate of the sampled CSV (125 CB3, 500 e-Series)

  // --- what it was designed for / under
  /// URDF of the robot. In the file it is relative to the trajectory file's directory (or
  /// absolute); readTrajectoryFile resolves it, writeTrajectoryFile writes it relative again.
  std::string robot;
  TrajectoryConstraints constraints;
  std::map<std::string, std::string> design;    ///< model, objective, seed, algorithms, budgets...
  std::map<std::string, double> metrics;        ///< achieved figures (condition_number, ...)
  std::map<std::string, double> predicted_std;  ///< parameter -> predicted standard error (SI)

  FourierTrajectory toTrajectory() const;
  /// Period count duration * f_base (must be a whole number for rest-to-rest).
  double periods() const { return duration_s * base_frequency_hz; }
};

/// Reads traj.yaml. Throws ConfigError("FILE: key 'x': message") on anything missing or invalid.
TrajectoryFile readTrajectoryFile(const std::string& path);
/// The same from text already in memory (`path` names it in messages; the fuzz target's entry).
TrajectoryFile parseTrajectoryText(const std::string& text, const std::string& path);

/// Writes traj.yaml atomically (temporary file + rename); doubles round-trip exactly.
void writeTrajectoryFile(const std::string& path, const TrajectoryFile& file);

/// Samples the trajectory at rate_hz over [0, duration] (both ends included when the duration is
/// a whole number of samples) and writes the CSV t, q1..q6, qd1..qd6, qdd1..qdd6 atomically.
void writeTrajectoryCsv(const std::string& path, const FourierTrajectory& trajectory,
                        double rate_hz);

/// traj.yaml -> traj.csv beside it (same stem).
std::string csvPathFor(const std::string& yaml_path);

}  // namespace ftid::trajectory
