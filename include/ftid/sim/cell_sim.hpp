#pragma once
// Cell simulator: a UR arm moving a payload on a wrist F/T+IMU sensor, producing logs
// (docs/log-format.md) from first-principles rigid-body physics. Physics and every switch with its
// equations: docs/simulator.md. Frames, units and signs: docs/conventions.md.
//
// The simulator computes the wrench by its own route (direct Newton-Euler of the payload given
// the sensor-frame motion from model::RobotKinematics); it never calls the identification
// regressors, so tests can compare two independent formulations.
//
// Typical use:
//   sim::CellSimConfig cfg = sim::paperCellConfig(model::RobotKinematics::fromUrdfFile("config/ur10.urdf"));
//   cfg.seed = 7; cfg.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
//   cfg.sensor_delay.enabled = true;
//   logio::LogData log = sim::CellSim(cfg).run();
#include <cstdint>
#include <functional>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "ftid/common/types.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/trajectory/fourier_trajectory.hpp"

namespace ftid::sim {

/// True payload: mass, centre of mass c = p_SC_S and rotational inertia about C (axes of S).
struct PayloadTruth {
  double mass_kg = 0.0;
  Vec3 p_SC_S = Vec3::Zero();       ///< [m]
  Mat3 I_C_S = Mat3::Zero();        ///< inertia tensor about C, in S [kg m^2] (symmetric, PSD)
};

/// Gaussian noise (standard deviations). Zero means noise-free for that channel. The IMU and
/// temperature noise is white; the wrench noise is white unless filtered or oversampled:
///   sub-samples at K * rate_hz (K = wrench_oversample), each with noise n_j of std wrench_std,
///   white, or 1st-order low-pass filtered at wrench_lowpass_hz (an AR(1) recursion
///   n_j = phi n_{j-1} + sqrt(1 - phi^2) e_j, phi = exp(-2 pi f_c / (K rate)), so the marginal std
///   stays wrench_std); the logged sample is the mean of its K sub-samples (noise and signal, the
///   K sub-sample instants centred on t). docs/simulator.md.
struct NoiseConfig {
  Vec6 wrench_std = Vec6::Zero();   ///< per axis fx..tz [N, Nm] (of one sub-sample)
  double wrench_lowpass_hz = 0.0;   ///< cut-off of the 1st-order noise filter [Hz] (0 = white)
  int wrench_oversample = 1;        ///< K sub-samples averaged into each logged sample (>= 1)
  double acc_std = 0.0;             ///< accelerometer, each axis [m/s^2]
  double gyro_std = 0.0;            ///< angular velocity, each axis [rad/s]
  double alpha_std = 0.0;           ///< angular acceleration, each axis [rad/s^2]
  double temp_std = 0.0;            ///< temperature reading [degC]
};

/// Sensor temperature over time: warm-up exponential plus a slow sinusoid (not monotonic, so
/// temperature and time can be told apart):
///   T(t) = start + warmup_rise (1 - exp(-t / warmup_tau)) + sine_amplitude sin(2 pi t / sine_period)
struct TemperatureProfile {
  double start_degC = 24.0;
  double warmup_rise_degC = 6.0;
  double warmup_tau_s = 4.0;
  double sine_amplitude_degC = 1.5;
  double sine_period_s = 7.0;
  /// Optional override: T(t) from any function (e.g. a measured profile).
  std::function<double(double t_s)> custom;
  double at(double t_s) const;
};

/// Hidden effects (docs/simulator.md). Each switch is off by default.
struct CableSwitch {
  bool enabled = false;
  double stiffness_N_per_m = 3.0;                ///< k; linear spring, rest length 0
  Vec3 p_SA_S = Vec3(0.0, 0.03, 0.05);           ///< attachment point on the tool, in S [m]
  Vec3 p_BA_B = Vec3(-0.7, -0.3, 1.4);           ///< fixed anchor in the base frame B [m]
};
struct TemperatureDriftSwitch {
  bool enabled = false;
  double reference_degC = 25.0;                  ///< offsets equal F0, T0 at this temperature
  Vec3 dF0_dT_N_per_degC = Vec3(0.05, -0.04, 0.08);
  Vec3 dT0_dT_Nm_per_degC = Vec3(0.002, -0.003, 0.0015);
};
struct TimeDriftSwitch {
  bool enabled = false;                          ///< offsets drift linearly from t = 0
  Vec3 dF0_dt_N_per_s = Vec3(0.02, -0.015, 0.03);
  Vec3 dT0_dt_Nm_per_s = Vec3(0.001, 0.0008, -0.0012);
};
struct SensorDelaySwitch {
  bool enabled = false;
  double tau_s = 0.012;                          ///< wrench stream lags kinematics/IMU by tau
                                                 ///< (negative: leads), |tau| < 1 s
};
/// Glitches: isolated spikes (CAN bus errors, EMI). Each logged sample carries one with
/// probability `probability`, on one axis drawn uniformly from fx..tz, with a random sign and the
/// magnitude of that axis type. Drawn from their own random stream (seed-derived), so switching
/// glitches on does not change the noise.
struct GlitchSwitch {
  bool enabled = false;
  double probability = 0.004;                    ///< per logged sample
  double force_N = 10.0;                         ///< spike on a force axis
  double torque_Nm = 1.0;                        ///< spike on a torque axis
};
/// Saturation (issue 22): the sensor's range per axis; a reading beyond +-limit reads the limit
/// (clipped after noise, glitches and averaging, as the sensor's electronics do). 0 = no limit.
struct SaturationSwitch {
  Vec6 limit = Vec6::Zero();                     ///< [N, Nm] per axis fx..tz
};
/// A compliant mount (issue 22): the tool rings on it, and the sensor reads the rigid wrench u
/// through y'' + 2 zeta w_n y' + w_n^2 y = w_n^2 u on each axis (w_n = 2 pi f_n), integrated by RK4
/// in 16 steps per sample with u linear in between, from rest (y = u(0), y' = 0); before the noise.
/// Moving runs only (a static pose set has no time between its poses).
struct MountDynamicsSwitch {
  bool enabled = false;
  double f_n_hz = 3.0;                           ///< natural frequency [Hz]
  double zeta = 0.1;                             ///< damping ratio
};
/// The sensor is mounted rotated against the configured X_FS: its true frame S' has
/// R_SS' = Rz(yaw) Ry(pitch) Rx(roll) in the configured S (same origin). The sensor reports the
/// wrench (and, with rotate_imu, the IMU it carries) in S': w' = [R_SS'^T f; R_SS'^T t]; its offsets
/// and crosstalk belong to the sensor and apply in S'.
struct MountingSwitch {
  bool enabled = false;
  Vec3 rpy_rad = Vec3(0.0, 0.0, 0.05235987755982988);  ///< roll, pitch, yaw (default 3 deg yaw)
  bool rotate_imu = true;
  Mat3 rotation() const;                         ///< R_SS'
};
/// Static pose sets (the usual calibration data): `poses` poses, each held still for hold_s
/// (samples at rate_hz, qd = qdd = 0), pose k = the configured motion's q at
/// (k + 0.5) span / poses (span = span_s, or the trajectory's duration when 0). With `average`,
/// each hold is logged as one reading: the mean of its samples (wrench, IMU, temperature), at the
/// hold's mid time. Replaces duration_s: the run lasts poses * hold_s (each hold rounded to a whole
/// number of samples, at least one).
struct StaticPoseSetSwitch {
  bool enabled = false;
  int poses = 100;
  double hold_s = 0.4;
  bool average = false;
  double span_s = 0.0;
};
/// Errors of the sensor's IMU (docs/simulator.md): constant biases added to the accelerometer and
/// gyro readings (in the IMU's frame: S, or S' with mounting.rotate_imu) and a delay of the IMU
/// stream: with delay_s = tau_i the IMU sample stamped t is the exact IMU reading of t - tau_i
/// (independent of sensor_delay, which moves the wrench only). |delay_s| < 1 s.
struct ImuErrorSwitch {
  bool enabled = false;
  Vec3 acc_bias_mps2 = Vec3(0.03, -0.02, 0.04);   ///< accelerometer bias [m/s^2]
  Vec3 gyro_bias_radps = Vec3(0.002, -0.003, 0.001);  ///< gyro bias [rad/s]
  double delay_s = 0.0;                          ///< IMU stream lags the kinematics by this [s]
};
struct CrosstalkSwitch {
  bool enabled = false;
  Mat6 E = defaultMatrix();                      ///< reading = (I + E) * load wrench + offsets
  static Mat6 defaultMatrix();
};
struct ContactSwitch {
  bool enabled = false;
  double t_start_s = 4.0;                        ///< push window [t_start, t_end]
  double t_end_s = 6.0;
  Vec3 force_B = Vec3(0.0, 0.0, -8.0);           ///< peak force on the tool, in B [N]
  Vec3 p_SP_S = Vec3(0.0, 0.0, 0.12);            ///< point of application on the tool, in S [m]
  /// Window shape s(t) = sin^2(pi (t - t_start) / (t_end - t_start)) inside, 0 outside.
  double profile(double t_s) const;
};

/// The payload changes at t_s (an object is grasped): from then on the sensor also holds `added`, a
/// second rigid body whose Newton-Euler wrench (same formulation as the payload's) is added to the
/// payload's. The identified parameters then describe the payload before the grasp only. With
/// `released`, the sensor holds `added` from the start and lets it go at t_s (a release).
struct PayloadChangeSwitch {
  bool enabled = false;
  double t_s = 5.0;
  PayloadTruth added;
  bool released = false;
  /// Whether `added` is on the sensor at t_s_now: (t >= t_s) for a grasp, (t < t_s) for a release.
  bool holds(double t_s_now) const { return enabled && ((t_s_now >= t_s) != released); }
};

struct CellSimConfig {
  std::optional<model::RobotKinematics> robot;   ///< required
  Mat3 R_FS = Mat3::Identity();                  ///< sensor mount X_FS
  Vec3 p_FS_F = Vec3::Zero();
  trajectory::FourierTrajectory trajectory;      ///< used unless `motion` is set
  std::function<trajectory::TrajectoryPoint(double t_s)> motion;  ///< optional q(t) provider
  double rate_hz = 125.0;                        ///< samples t_k = k / rate_hz, k = 0..N-1
  double duration_s = 10.0;                      ///< N = floor(duration * rate) + 1
  PayloadTruth payload;
  double tilt_u_rad = 0.0;                       ///< R_WB = Rx(U) Ry(V)
  double tilt_v_rad = 0.0;
  Vec3 F0_N = Vec3::Zero();                      ///< sensor force offsets
  Vec3 T0_Nm = Vec3::Zero();                     ///< sensor torque offsets
  NoiseConfig noise;
  std::uint64_t seed = 1;                        ///< std::mt19937_64 seed
  /// true: full Newton-Euler. false: the paper's model only (f = m(g_S - a_S), t = c x f).
  bool full_rigid_body = true;
  TemperatureProfile temperature;
  CableSwitch cable;
  TemperatureDriftSwitch temperature_drift;
  TimeDriftSwitch time_drift;
  SensorDelaySwitch sensor_delay;
  CrosstalkSwitch crosstalk;
  ContactSwitch contact;
  /// More pushes, each like `contact` (its own window, force and point; `enabled` is ignored: every
  /// entry pushes). Their wrench is part of the load and of the contact truth columns.
  std::vector<ContactSwitch> pushes;
  PayloadChangeSwitch payload_change;
  GlitchSwitch glitches;
  SaturationSwitch saturation;  ///< saturation (issue 22)
  MountDynamicsSwitch mount_dynamics;  ///< a compliant mount (issue 22)
  MountingSwitch mounting;
  StaticPoseSetSwitch static_poses;
  ImuErrorSwitch imu;
};

/// One glitch of a run: logged sample index, axis 0..5 and the spike added [N or Nm].
struct Glitch {
  std::size_t sample = 0;
  int axis = 0;
  double value = 0.0;
};

/// One noise-free (or noisy, after addNoise) sensor sample.
struct SensorReading {
  Wrench wrench_S = Wrench::Zero();   ///< what the sensor reports (offsets, effects included)
  Vec3 acc_S = Vec3::Zero();          ///< IMU specific force R_WS^T (a_W - g_W)
  Vec3 w_S = Vec3::Zero();
  Vec3 alpha_S = Vec3::Zero();
  double temp_degC = 0.0;
  Wrench contact_S = Wrench::Zero();  ///< true contact wrench [F; p x F] in S (zero if no contact)
};

class CellSim {
 public:
  /// Validates the configuration; throws ConfigError naming the field.
  explicit CellSim(CellSimConfig config);

  /// Simulates the whole run: columns t, q, qd, qdd, wrench, IMU, temp (+ contact_fx..contact_tz
  /// truth columns when the contact switch is on). Same config and seed -> identical log.
  /// Glitches are added to the logged (averaged) samples; static pose sets replace the time grid.
  logio::LogData run() const;

  // --- Per-instant API (e.g. for a sensor simulator fed by a robot simulator) -----------------
  // All noise-free and deterministic; thread-compatible (const, no shared mutable state except
  // KDL's internal joint-pose cache: use one CellSim per thread).

  /// Load wrench on the sensor (payload Newton-Euler + cable + contact), in S, before crosstalk
  /// and offsets, for the robot state (q, qd, qdd) at time t_s.
  Wrench loadWrenchAt(const JointVector& q, const JointVector& qd, const JointVector& qdd,
                      double t_s) const;

  /// The undelayed sensor reading for the robot state (q, qd, qdd) at time t_s and sensor
  /// temperature temp_degC: wrench = (I + E) load + F0/T0 (+ drift terms); IMU from the same state.
  /// The sensor_delay switch is NOT applied here (it needs the state at t - tau: callers holding a
  /// state history call this with the state of t - tau for the wrench; see sensorDelay()).
  SensorReading readingAt(const JointVector& q, const JointVector& qd, const JointVector& qdd,
                          double t_s, double temp_degC) const;
  /// As above with the temperature from the configured profile.
  SensorReading readingAt(const JointVector& q, const JointVector& qd, const JointVector& qdd,
                          double t_s) const;

  /// The noise-free sample at time t_s of the configured trajectory, with every switch applied
  /// exactly (sensor_delay: the wrench is readingAt(state(t - tau), t - tau).wrench_S).
  SensorReading sampleAt(double t_s) const;

  /// Adds the configured white noise to a reading (draw order: 6 wrench, 3 acc, 3 gyro,
  /// 3 alpha, 1 temp; always drawn, so switching effects on does not change the noise). The wrench
  /// part is added only when the wrench noise is white and not oversampled (else run() adds it).
  void addNoise(SensorReading& reading, std::mt19937_64& rng) const;
  /// The glitches run() adds (same seed -> same glitches), in sample order.
  std::vector<Glitch> glitches() const;

  /// Sensor offsets at time t and temperature T, including drift switches.
  Wrench offsetsAt(double t_s, double temp_degC) const;
  double temperatureAt(double t_s) const { return config_.temperature.at(t_s); }
  /// Delay of the wrench stream (0 when the switch is off).
  double sensorDelay() const { return config_.sensor_delay.enabled ? config_.sensor_delay.tau_s : 0.0; }
  trajectory::TrajectoryPoint stateAt(double t_s) const;
  std::size_t sampleCount() const;

  const CellSimConfig& config() const { return config_; }

  /// Switches the contact push on for [t_start_s, t_end_s] (force and point as configured). For a
  /// simulator driven live (ftid sim-sensor starts a push on request). Not thread-safe with the
  /// per-instant readers: call it from the thread that uses them.
  void setContactWindow(double t_start_s, double t_end_s);
  /// The configured payload change (payload_change.added, e.g. `grasp`) happens at t_s from now
  /// on (the sensor simulator's "grasp now"). Throws ConfigError if t_s is not finite.
  void setPayloadChangeTime(double t_s);
  const model::RobotKinematics& robot() const { return *config_.robot; }

 private:
  Wrench loadWrenchFor(const model::SensorMotion& m, double t_s) const;
  /// The contact wrench (contact switch plus pushes) in S at t_s for the sensor pose R_BS.
  Wrench contactWrenchAt(const Mat3& R_BS, double t_s) const;
  bool hasContacts() const { return config_.contact.enabled || !config_.pushes.empty(); }
  std::size_t samplesPerHold() const;
  CellSimConfig config_;
  Vec3 g_B_;
};

/// The truth of a configuration as YAML text (parameter names of docs/conventions.md plus every
/// switch with its magnitudes), and an atomic file writer for it (tmp file + fsync + rename).
std::string truthYaml(const CellSimConfig& config);
void writeTruthYaml(const std::string& path, const CellSimConfig& config);

/// The paper's Table 2 payload (Duan et al. 2022): offsets, centre of mass, weight, tilt.
struct PaperPayload {
  static constexpr double kWeight_N = 8.862;
  static constexpr double kMass_kg = 8.862 / kStandardGravity;
  static constexpr double kTiltU_deg = -9.8716;
  static constexpr double kTiltV_deg = -5.3709;
  static Vec3 forceOffset() { return Vec3(-0.6672, 0.8565, 0.3538); }
  static Vec3 torqueOffset() { return Vec3(0.0228, 0.0084, 0.0080); }
  static Vec3 centreOfMass() { return Vec3(0.005, 0.002, 0.051); }
  /// Mass and centre of mass of Table 2, with a nominal inertia (solid cylinder r = 0.04 m,
  /// h = 0.10 m about its centre; the paper gives none).
  static PayloadTruth payload();
  /// Sets payload, F0, T0 and tilt of `config`.
  static void apply(CellSimConfig& config);
};

/// Start pose of the paper-style excitation: (0, -1.57, 1.57, -1.57, -1.57, 0) rad.
JointVector paperStartPose();
/// Paper-style excitation: 10 s, 5 harmonics, 0.1 Hz base, joints 4-6 excited, rest-to-rest,
/// within UR10 velocity limits (hand-picked coefficients; docs/simulator.md).
trajectory::FourierTrajectory paperExcitationTrajectory();
/// A complete paper cell: robot, PaperPayload, paper trajectory, 125 Hz, 10 s, no noise, no effects.
CellSimConfig paperCellConfig(model::RobotKinematics robot);

}  // namespace ftid::sim
