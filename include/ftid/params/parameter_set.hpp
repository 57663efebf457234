#pragma once
// The identified parameters in a form that outlives the fit: what a parameter file holds
// (docs/identification.md) and what `ftid identify --json` prints.
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "ftid/common/types.hpp"
#include "ftid/effects/nonlinear.hpp"


namespace ftid::params {

struct NamedValue {
  std::string name;
  double value = 0.0;
  double std = 0.0;
  std::string unit;
};

struct Provenance {
  std::string date_utc;      ///< ISO 8601
  std::string data_file;
  std::string method;        ///< "paper-static", "paper-dynamic", "fit"
  std::string trajectory;    ///< if known
  int n_samples = 0;
};

struct ParameterSet {
  std::string model;                 ///< canonical model name, e.g. "paper"
  /// The model's parameters in any order: the linear ones (theta) and, for models with
  /// `mounting` / `sensor_delay`, mount_roll/pitch/yaw [rad] and delay [s].
  std::vector<NamedValue> params;
  std::vector<NamedValue> derived;   ///< mass-derived quantities (com_*, weight), informational
  bool tilt_estimated = false;
  double tilt_u_rad = 0.0;
  double tilt_v_rad = 0.0;
  double tilt_u_std = 0.0;
  double tilt_v_std = 0.0;
  Vec6 residual_rms = Vec6::Zero();  ///< fx..tz
  double condition_number = 0.0;
  std::vector<NamedValue> extras;    ///< e.g. per-stage condition numbers (JSON "extras")
  /// The time origin of the model's time [s, Unix time, UTC] (docs/conventions.md, "Time and
  /// logs"): `time_drift` and the `t` signal read seconds since this instant, the offsets hold at
  /// it. The host_time of the identification log's first sample; NaN if the log had no host_time
  /// column (and in files written before time origins: the drift then runs from the start of
  /// the run, ftidd's first valid cycle or the log's first sample). File key `time_origin`.
  double time_origin_unix_s = std::numeric_limits<double>::quiet_NaN();
  /// The sensor IMU's biases in its own frame, as `ftid identify` estimated them with the IMU
  /// (file key `imu`; names kImuBiasNames, units m/s^2 and rad/s); empty when the IMU was not
  /// used. Read by compensation with the motion from the IMU (docs/effects.md "Motion from the IMU").
  std::vector<NamedValue> imu;
  Provenance provenance;

  /// Finds a parameter in params, derived or tilt ("tilt_u"/"tilt_v"); nullptr if absent.
  const NamedValue* find(const std::string& name) const;
};

/// The names an `imu` entry may have: the accelerometer's bias [m/s^2], then the gyro's [rad/s].
inline constexpr const char* kImuBiasNames[6] = {"acc_bias_x",  "acc_bias_y",  "acc_bias_z",
                                                 "gyro_bias_x", "gyro_bias_y", "gyro_bias_z"};

/// Largest IMU bias a parameter set may hold (findParameterProblem): ten times a poor MEMS part's.
inline constexpr double kMaxImuAccBias_mps2 = 2.0;
inline constexpr double kMaxImuGyroBias_radps = 0.2;

/// The IMU's biases from the set: the six values in kImuBiasNames' order, zero where the set has
/// none (an accelerometer bias the motion did not determine, or a set identified without the IMU).
Vec6 imuBiasesOf(const ParameterSet& set);

/// theta for `model` (ordered as model.paramIndex()) from the set. Throws ConfigError naming the
/// source (file) and the missing parameter.
Eigen::VectorXd thetaFor(const effects::Model& model, const ParameterSet& set,
                         const std::string& source = "parameter set");

/// The nonlinear parameters for `model` from the set (tilt always; mounting and delay when the
/// model estimates them). Throws ConfigError naming the source and the missing parameter.
effects::NonlinearParams nonlinearFor(const effects::Model& model, const ParameterSet& set,
                                      const std::string& source = "parameter set");

/// A problem that makes a parameter set unusable: the key (e.g. "parameters.mass") and why.
struct ParameterProblem {
  std::string key;
  std::string message;
};

/// Relative tolerance of the inertia checks (rounding only, not uncertainty).
inline constexpr double kInertiaRelativeTolerance = 1e-9;

/// First reason the set is not physically possible, if any, whatever its standard errors: a
/// non-finite value or standard error; a non-positive `mass`; a non-finite centre of mass; with
/// rigid_body's i_s_* parameters, an inertia about the centre of mass with a negative principal
/// moment or a violated triangle inequality (beyond kInertiaRelativeTolerance of the tensor's
/// scale; effects::inertiaAboutCom); an IMU bias beyond kMaxImuAccBias_mps2 / kMaxImuGyroBias_radps.
std::optional<ParameterProblem> findParameterProblem(const ParameterSet& set);

/// What the robot and the sensor can carry (issue 26): a set beyond them is implausible
/// (a log with a wrong scale, a hand-edited file) and is refused before it is loaded or written.
struct PlausibilityLimits {
  /// The robot's rated payload [kg] (UR10 10, UR10e 12.5); infinity = no limit.
  double max_payload_kg = std::numeric_limits<double>::infinity();
  std::string payload_source;  ///< where the limit came from, for messages (file and key)
  /// The sensor's rated range |Fx| |Fy| |Fz| [N] |Tx| |Ty| |Tz| [Nm]; infinity = no limit.
  Vec6 sensor_range = Vec6::Constant(std::numeric_limits<double>::infinity());
  std::string range_source;  ///< e.g. the DBC file whose signal ranges these are
  double gravity_mps2 = 9.81;
};

/// findParameterProblem(set), then plausibility: `mass` above limits.max_payload_kg; or a static
/// model wrench beyond the sensor's rated range in the worst orientation: per force axis
/// |f0_a| + m g, per moment axis |t0_a| + g |(m c) perpendicular to a| (the sensor reads offsets
/// plus gravity load; every orientation is reachable, so the worst one bounds what it must carry).
std::optional<ParameterProblem> findParameterProblem(const ParameterSet& set, const PlausibilityLimits& limits);

/// For an identified set whose rigid-body inertia is physically impossible but within 3 standard
/// errors of a possible one (effects::inertiaAboutCom's valid_within_uncertainty; a small payload's
/// inertia estimate lands outside now and then): replaces i_s_* by the nearest possible inertia,
/// the Euclidean projection of the principal moments about the centre of mass onto the
/// physically possible set (non-negative, each at most the sum of the other two), in the same
/// principal axes, and notes it in provenance.method. Returns a one-line description of the
/// change ("" if nothing changed). Projected only if (a) a possible tensor lies within 3 standard
/// errors and (b) every i_s_* standard error is at most 10 % of the estimated tensor's largest
/// |eigenvalue| (an estimate that is mostly noise, e.g. i_s_xx = -5 with std 100, is not an
/// inertia to correct); otherwise the set is left as it is (refused by findParameterProblem) and
/// `refused` (if given) gets the reason. Used by `ftid identify --out` and `ftid --identify`.
std::string projectInertiaWithinUncertainty(ParameterSet* set, std::string* refused = nullptr);

/// Reads a parameter file (YAML): a regular file, no duplicate keys, every value finite, and
/// findParameterProblem() empty. Throws ConfigError naming the file, line and key.
ParameterSet readParameterFile(const std::string& path);
/// The same from text already in memory (`path` names it in messages; the fuzz target's entry).
ParameterSet parseParameterText(const std::string& text, const std::string& path);
/// Writes it atomically through ftid::writeFileAtomically (never over a symlink, device, FIFO or
/// directory); an existing file is kept as PATH.bak. Throws IdentificationError (and writes
/// nothing, rotates nothing) if findParameterProblem() finds a problem.
void writeParameterFile(const std::string& path, const ParameterSet& set);

/// The `ftid identify --json` object (one line of JSON, no trailing newline).
std::string toJson(const ParameterSet& set);

}  // namespace ftid::params
