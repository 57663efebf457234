#pragma once
// NLopt excitation-trajectory designer (docs/design.md).
//
//   1. parametrise: rest-to-rest Fourier coefficients of the selected joints (parametrization.hpp)
//   2. global stage: GN_ISRES (NLopt, seeded with nlopt::srand) or a seeded multistart of random
//      feasible trajectories refined briefly by COBYLA; then local refinement of the best point
//      (LN_COBYLA, LD_SLSQP with finite-difference gradients, or LN_AUGLAG + LN_SBPLX)
//   3. objective: condition number (or D-optimality) of the model's stacked regressor along the
//      trajectory (excitation_metric.hpp), computed through the identification's context builder;
//      or, for accuracy limits, the soft maximum of predicted std / target (Objective::kLimits)
//   4. constraints inside NLopt: joint position/velocity/acceleration limits, floor plane and
//      keep-out spheres, each aggregated over the design samples with a Kreisselmeier-Steinhauser
//      soft maximum (smooth, conservative), with a small relative margin
//   5. after NLopt: dense, independent re-check (trajectory_check.hpp); a violating result is
//      scaled back into the feasible set (amplitude bisection) and re-checked, or rejected
//   6. baselines: random feasible Fourier trajectories of the same duration (median cond over
//      seeds) and the static six-pose method; predicted parameter standard errors
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <map>
#include <string>
#include <vector>

#include "ftid/common/error.hpp"
#include "ftid/design/trajectory_check.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/trajectory/trajectory_io.hpp"

namespace ftid::design {

/// The designer could not produce a trajectory meeting the request (infeasible, no excitation,
/// NLopt failure). The message says what to relax.
class DesignError : public Error {
 public:
  using Error::Error;
};

/// What the designer minimises (docs/design.md "Objective"): the column-scaled condition number,
/// D-optimality, or, for accuracy limits, the worst ratio of a predicted standard error to its
/// target (DesignOptions::limit_targets; with the IMU's information when targets_with_imu).
enum class Objective { kCondition, kDOptimality, kLimits };
/// The objective's name on the command line and in the design record: cond, dopt, limits.
const char* objectiveName(Objective o);

struct DesignOptions {
  std::string model = "paper";
  std::string robot_path = "config/ur10.urdf";  ///< recorded in the output
  std::vector<int> joints{4, 5, 6};             ///< 1-based
  double duration_s = 10.0;
  int periods = 1;  ///< base frequency = periods / duration
  int harmonics = 5;
  double servo_rate_hz = 125.0;  ///< CSV rate and samples the identification sees
  JointVector q0 = (JointVector() << 0.0, -1.5707963267948966, 1.5707963267948966,
                    -1.5707963267948966, -1.5707963267948966, 0.0)
                       .finished();
  Objective objective = Objective::kCondition;
  std::uint64_t seed = 1;
  double time_budget_s = 30.0;                  ///< wall-clock cap for the whole design
  std::string global_algorithm = "multistart";  ///< multistart | isres | none
  std::string local_algorithm = "cobyla";       ///< cobyla | slsqp | auglag | none
  long global_max_evals = 0;                    ///< 0: limited by the time budget only
  long local_max_evals = 0;
  int design_samples = 0;           ///< samples for the objective (0: automatic)
  double constraint_margin = 0.01;  ///< relative margin on joint limits inside NLopt
  double max_condition = 1e4;       ///< above this the request counts as infeasible
  Vec6 noise_sigma = (Vec6() << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01).finished();  ///< [N, Nm]
  std::map<std::string, double> nominal;  ///< empty: paper Table 2 payload
  trajectory::TrajectoryConstraints constraints;
  /// The sensor's IMU noise (white, per axis) for the predictions with the IMU (docs/design.md
  /// "Limits"); 0: no IMU prediction.
  double imu_acc_std = 0.0;   ///< accelerometer [m/s^2]
  double imu_gyro_std = 0.0;  ///< gyro [rad/s]
  /// findShortestDuration and Objective::kLimits: judge the targets on the predictions with the
  /// IMU (needs the IMU noise).
  bool targets_with_imu = false;
  /// Objective::kLimits: predicted standard-error targets by key (parseTargets/parseLimits keys).
  std::map<std::string, double> limit_targets;
  int baseline_seeds = 50;  ///< random baseline trajectories (0: skip)
  bool static_baseline = true;
  std::ostream* progress = nullptr;  ///< progress lines (stderr in the CLI)
};

struct BaselineReport {
  double random_median_condition = 0.0;  ///< median over random feasible trajectories
  int random_count = 0;
  double static_condition = 0.0;  ///< six static poses (0 if not found)
  std::vector<JointVector> static_poses;
  std::map<std::string, double> static_std;  ///< six-pose method, same sample count as the design
};

struct DesignResult {
  trajectory::TrajectoryFile file;  ///< ready to write (coefficients, constraints, design, metrics)
  double condition_number = 0.0;    ///< at the servo rate, column-scaled
  double d_optimality = 0.0;
  std::map<std::string, double> predicted_std;
  /// The same with the IMU's tilt fused (DesignOptions::imu_acc_std > 0 and a model with tilt).
  std::map<std::string, double> predicted_std_imu;
  CheckReport check;  ///< dense re-check of the final trajectory
  BaselineReport baselines;
  std::string global_result;  ///< NLopt outcome, human-readable
  std::string local_result;
  long global_evals = 0;
  long local_evals = 0;
  double elapsed_s = 0.0;
  bool repaired = false;  ///< NLopt's point violated the dense check and was scaled back
  std::vector<std::string> warnings;
};

/// Designs one trajectory. Throws ConfigError for invalid options, DesignError if no acceptable
/// trajectory exists (with the reason and what to relax).
DesignResult designExcitation(const DesignOptions& options,
                              const model::RobotKinematics& kinematics);

/// Standard-error targets, e.g. "mass=0.005,com=0.001" (SI units; "mass=0.5%" is relative to the
/// nominal value). Keys: any metric column, derived com_x/y/z, weight, or the groups com, f0, t0,
/// tilt. Throws ConfigError naming the bad item.
std::map<std::string, double> parseTargets(const std::string& text,
                                           const std::map<std::string, double>& nominal);
/// Names of the targets that a predicted-std map misses (empty: all met). Lists unknown keys too.
std::vector<std::string> unmetTargets(const std::map<std::string, double>& predicted,
                                      const std::map<std::string, double>& targets);
/// Throws ConfigError naming each target key that the model options.model does not predict (a
/// typo such as "mas", or a parameter of another model): no design could meet such a target, and
/// the limits objective would be flat. The message lists the keys the model predicts.
void checkTargetNames(const DesignOptions& options, const model::RobotKinematics& kinematics,
                      const std::map<std::string, double>& targets);

struct DurationTrial {
  double duration_s = 0.0;
  bool met = false;
  double condition_number = 0.0;
  std::map<std::string, double> predicted_std;
  std::map<std::string, double> predicted_std_imu;  ///< with the IMU (if its noise was given)
};

/// Accuracy limits, e.g. "mass=0.5%,com=1mm,tilt=0.1deg": the keys of parseTargets, each value a
/// number with an optional unit (%, relative to the nominal value; mm, cm, m; deg, rad; g, kg; N,
/// Nm), converted to SI. The designer meets a limit L when the predicted worst case over noise,
/// kLimitStandardErrors (3) predicted standard errors, is within it: targets = L / 3. Throws
/// ConfigError naming the bad item.
inline constexpr double kLimitStandardErrors = 3.0;
std::map<std::string, double> parseLimits(const std::string& text, const std::map<std::string, double>& nominal);
struct DurationSearchResult {
  std::vector<DurationTrial> trials;
  bool found = false;
  DesignResult best;  ///< the design at the shortest duration meeting the targets
};

/// Shortest duration (resolution `step_s`, one base period) whose design meets the targets: grows
/// the duration from options.duration_s by doubling until met (up to max_duration_s), then bisects.
/// Each design gets an equal share of options.time_budget_s.
DurationSearchResult findShortestDuration(const DesignOptions& options,
                                          const model::RobotKinematics& kinematics,
                                          const std::map<std::string, double>& targets,
                                          double step_s = 0.5, double min_duration_s = 1.0,
                                          double max_duration_s = 60.0);

/// Human-readable NLopt result code / exception ("XTOL_REACHED: ...").
std::string describeNloptResult(int code);

/// Constraints from the robot (URDF position and velocity limits) merged with a design config file
/// (config/design.yaml): the tighter of the two wins. Throws ConfigError naming file and key.
/// An empty path gives URDF limits plus built-in defaults (floor, keep-out, tool as in the file).
trajectory::TrajectoryConstraints loadDesignConstraints(const std::string& config_path,
                                                        const model::RobotKinematics& kinematics,
                                                        const JointVector& q0);

}  // namespace ftid::design
