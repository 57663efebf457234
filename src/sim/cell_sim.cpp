// Cell simulator physics (docs/simulator.md). The payload wrench is computed by direct
// Newton-Euler from the sensor-frame motion; nothing here uses the identification regressors.
#include "ftid/sim/cell_sim.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Eigenvalues>

#include "ftid/common/error.hpp"

namespace ftid::sim {

namespace {
constexpr double kPi = 3.141592653589793;

void require(bool ok, const std::string& field, const std::string& what) {
  if (!ok) throw ConfigError("cell simulator config: " + field + ": " + what);
}
bool finite3(const Vec3& v) { return v.allFinite(); }
}  // namespace

double TemperatureProfile::at(double t_s) const {
  if (custom) return custom(t_s);
  double T = start_degC;
  if (warmup_tau_s > 0.0) T += warmup_rise_degC * (1.0 - std::exp(-std::max(t_s, 0.0) / warmup_tau_s));
  if (sine_period_s > 0.0) T += sine_amplitude_degC * std::sin(2.0 * kPi * t_s / sine_period_s);
  return T;
}

Mat6 CrosstalkSwitch::defaultMatrix() {
  // Small gain errors on the diagonal and cross-axis couplings (1-2 %), typical of a strain-gauge
  // sensor with an imperfect calibration matrix. Torque rows in Nm per N (force->torque) are
  // scaled by a 0.05 m lever so their effect is comparable to the others.
  Mat6 E;
  E << 0.012, -0.008, 0.015, 0.0, 0.0, 0.0,
       0.010, -0.015, -0.006, 0.0, 0.0, 0.0,
       -0.012, 0.009, 0.018, 0.0, 0.0, 0.0,
       0.0005, -0.0004, 0.0, 0.015, -0.010, 0.006,
       -0.0003, 0.0006, 0.0, 0.008, -0.012, 0.010,
       0.0, 0.0004, -0.0005, -0.006, 0.011, 0.014;
  return E;
}

Mat3 MountingSwitch::rotation() const {
  return (Eigen::AngleAxisd(rpy_rad.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(rpy_rad.y(), Vec3::UnitY()) *
          Eigen::AngleAxisd(rpy_rad.x(), Vec3::UnitX()))
      .toRotationMatrix();
}

double ContactSwitch::profile(double t_s) const {
  if (!(t_s > t_start_s) || !(t_s < t_end_s)) return 0.0;
  const double s = std::sin(kPi * (t_s - t_start_s) / (t_end_s - t_start_s));
  return s * s;
}

CellSim::CellSim(CellSimConfig config) : config_(std::move(config)) {
  const auto& c = config_;
  require(c.robot.has_value(), "robot", "no robot kinematics given");
  require(c.R_FS.allFinite() && (c.R_FS.transpose() * c.R_FS - Mat3::Identity()).norm() < 1e-9 &&
              c.R_FS.determinant() > 0.0,
          "R_FS", "not a rotation matrix");
  require(finite3(c.p_FS_F), "p_FS_F", "not finite");
  require(std::isfinite(c.rate_hz) && c.rate_hz > 0.0, "rate_hz", "must be positive");
  require(std::isfinite(c.duration_s) && c.duration_s >= 0.0, "duration_s", "must be >= 0");
  require(c.duration_s * c.rate_hz < 1e8, "duration_s", "too many samples (duration * rate >= 1e8)");
  require(std::isfinite(c.payload.mass_kg) && c.payload.mass_kg >= 0.0, "payload.mass_kg", "must be >= 0");
  require(finite3(c.payload.p_SC_S), "payload.p_SC_S", "not finite");
  const Mat3& I = c.payload.I_C_S;
  require(I.allFinite() && (I - I.transpose()).norm() <= 1e-12 * (1.0 + I.norm()), "payload.I_C_S",
          "must be symmetric");
  {
    Eigen::SelfAdjointEigenSolver<Mat3> es(I);
    const Vec3 ev = es.eigenvalues();
    const double tol = 1e-12 * (1.0 + I.norm());
    require(ev.minCoeff() >= -tol, "payload.I_C_S", "not positive semi-definite");
    require(ev[0] + ev[1] >= ev[2] - tol, "payload.I_C_S", "violates the triangle inequality of principal moments");
  }
  require(std::isfinite(c.tilt_u_rad) && std::isfinite(c.tilt_v_rad), "tilt", "not finite");
  require(finite3(c.F0_N) && finite3(c.T0_Nm), "F0/T0", "not finite");
  require(c.noise.wrench_std.allFinite() && c.noise.wrench_std.minCoeff() >= 0.0, "noise.wrench_std", "must be >= 0");
  require(c.noise.acc_std >= 0.0 && c.noise.gyro_std >= 0.0 && c.noise.alpha_std >= 0.0 && c.noise.temp_std >= 0.0,
          "noise", "standard deviations must be >= 0");
  require(std::isfinite(c.cable.stiffness_N_per_m) && c.cable.stiffness_N_per_m >= 0.0, "cable.stiffness_N_per_m",
          "must be >= 0");
  require(finite3(c.cable.p_SA_S) && finite3(c.cable.p_BA_B), "cable", "points not finite");
  require(finite3(c.temperature_drift.dF0_dT_N_per_degC) && finite3(c.temperature_drift.dT0_dT_Nm_per_degC) &&
              std::isfinite(c.temperature_drift.reference_degC),
          "temperature_drift", "not finite");
  require(finite3(c.time_drift.dF0_dt_N_per_s) && finite3(c.time_drift.dT0_dt_Nm_per_s), "time_drift", "not finite");
  require(std::isfinite(c.sensor_delay.tau_s) && std::abs(c.sensor_delay.tau_s) < 1.0, "sensor_delay.tau_s",
          "must be in (-1, 1) s");
  require(std::isfinite(c.noise.wrench_lowpass_hz) && c.noise.wrench_lowpass_hz >= 0.0, "noise.wrench_lowpass_hz",
          "must be >= 0 (0 = white)");
  require(c.noise.wrench_oversample >= 1 && c.noise.wrench_oversample <= 1000, "noise.wrench_oversample",
          "must be 1..1000");
  require(std::isfinite(c.glitches.probability) && c.glitches.probability >= 0.0 && c.glitches.probability <= 1.0,
          "glitches.probability", "must be in [0, 1]");
  require(std::isfinite(c.glitches.force_N) && std::isfinite(c.glitches.torque_Nm), "glitches", "magnitudes not finite");
  require(c.saturation.limit.allFinite() && c.saturation.limit.minCoeff() >= 0.0, "saturation.limit",
          "must be >= 0 (0 = no limit)");  // saturation (issue 22)
  if (c.mount_dynamics.enabled) {
    require(std::isfinite(c.mount_dynamics.f_n_hz) && c.mount_dynamics.f_n_hz > 0.0 &&
                c.mount_dynamics.f_n_hz < 0.25 * c.rate_hz,
            "mount_dynamics.f_n_hz", "must be > 0 and below a quarter of the sample rate");
    require(std::isfinite(c.mount_dynamics.zeta) && c.mount_dynamics.zeta > 0.0, "mount_dynamics.zeta", "must be > 0");
    require(!c.static_poses.enabled, "mount_dynamics", "needs a moving run, not a static pose set");
  }
  require(c.mounting.rpy_rad.allFinite(), "mounting.rpy_rad", "not finite");
  require(c.imu.acc_bias_mps2.allFinite() && c.imu.gyro_bias_radps.allFinite(), "imu", "bias not finite");
  require(std::isfinite(c.imu.delay_s) && std::abs(c.imu.delay_s) < 1.0, "imu.delay_s", "must be finite with |delay| < 1 s");
  if (c.static_poses.enabled) {
    require(c.static_poses.poses >= 1 && c.static_poses.poses <= 1000000, "static_poses.poses", "must be 1..1e6");
    require(std::isfinite(c.static_poses.hold_s) && c.static_poses.hold_s > 0.0 &&
                c.static_poses.hold_s * c.rate_hz * c.static_poses.poses < 1e8,
            "static_poses.hold_s", "must be > 0 (and poses * hold * rate < 1e8)");
    require(std::isfinite(c.static_poses.span_s) && c.static_poses.span_s >= 0.0, "static_poses.span_s", "must be >= 0");
  }
  require(c.crosstalk.E.allFinite(), "crosstalk.E", "not finite");
  require(std::isfinite(c.contact.t_start_s) && std::isfinite(c.contact.t_end_s) &&
              c.contact.t_end_s > c.contact.t_start_s,
          "contact", "needs t_end_s > t_start_s");
  require(finite3(c.contact.force_B) && finite3(c.contact.p_SP_S), "contact", "force/point not finite");
  for (std::size_t i = 0; i < c.pushes.size(); ++i) {
    const ContactSwitch& push = c.pushes[i];
    const std::string field = "pushes[" + std::to_string(i) + "]";
    require(std::isfinite(push.t_start_s) && std::isfinite(push.t_end_s) && push.t_end_s > push.t_start_s,
            field, "needs t_end_s > t_start_s");
    require(finite3(push.force_B) && finite3(push.p_SP_S), field, "force/point not finite");
  }
  if (c.payload_change.enabled) {
    const PayloadTruth& a = c.payload_change.added;
    require(std::isfinite(c.payload_change.t_s), "payload_change.t_s", "not finite");
    require(std::isfinite(a.mass_kg) && a.mass_kg >= 0.0 && finite3(a.p_SC_S) && a.I_C_S.allFinite(),
            "payload_change.added", "needs a finite mass >= 0, centre of mass and inertia");
  }
  config_.robot->setSensorMount(c.R_FS, c.p_FS_F);
  // Gravity in B written out from the paper's Eq. 13 (R_WB = Rx(U) Ry(V), g_B = R_WB^T g_W), not
  // taken from model::gravityInBase: the tilt convention of the fit is then checked against an
  // independent formulation (a wrong rotation order in src/model fails the fit tests).
  const double U = c.tilt_u_rad, V = c.tilt_v_rad;
  g_B_ = kStandardGravity * Vec3(std::cos(U) * std::sin(V), -std::sin(U), -std::cos(U) * std::cos(V));
}

std::size_t CellSim::sampleCount() const {
  if (config_.static_poses.enabled) {
    const auto& sp = config_.static_poses;
    return static_cast<std::size_t>(sp.poses) * (sp.average ? 1u : samplesPerHold());
  }
  return static_cast<std::size_t>(std::floor(config_.duration_s * config_.rate_hz + 1e-9)) + 1;
}

std::size_t CellSim::samplesPerHold() const {
  return static_cast<std::size_t>(std::max(1.0, std::round(config_.static_poses.hold_s * config_.rate_hz)));
}

trajectory::TrajectoryPoint CellSim::stateAt(double t_s) const {
  if (config_.static_poses.enabled) {
    // Piecewise-constant poses taken from the configured motion, held still.
    const auto& sp = config_.static_poses;
    const double span = sp.span_s > 0.0 ? sp.span_s : (config_.motion ? config_.duration_s : config_.trajectory.duration());
    // The hold is a whole number of samples (samplesPerHold()), so rows and poses stay aligned.
    const double hold = static_cast<double>(samplesPerHold()) / config_.rate_hz;
    const int k = std::clamp(static_cast<int>(std::floor(t_s / hold + 1e-9)), 0, sp.poses - 1);
    const double tk = (k + 0.5) * span / sp.poses;
    trajectory::TrajectoryPoint x = config_.motion ? config_.motion(tk) : config_.trajectory.evaluate(tk);
    x.qd.setZero();
    x.qdd.setZero();
    return x;
  }
  if (config_.motion) return config_.motion(t_s);
  return config_.trajectory.evaluate(t_s);
}

Wrench CellSim::loadWrenchAt(const JointVector& q, const JointVector& qd, const JointVector& qdd,
                             double t_s) const {
  return loadWrenchFor(config_.robot->computeSensorMotion(q, qd, qdd), t_s);
}

namespace {

/// The wrench a held rigid body exerts on the sensor (Newton-Euler; paper model when !full).
Wrench heldBodyWrench(const PayloadTruth& p, const model::SensorMotion& m, const Vec3& g_S, bool full) {
  const Vec3& c = p.p_SC_S;
  Vec3 f, t;
  if (full) {
    // Newton-Euler of the payload: the sensor holds it, so the payload pushes on the sensor with
    // m (g - a_C) and the moment that is left after its angular momentum rate about C.
    const Vec3 a_C = m.a_S + m.alpha_S.cross(c) + m.w_S.cross(m.w_S.cross(c));
    f = p.mass_kg * (g_S - a_C);
    t = c.cross(f) - p.I_C_S * m.alpha_S - m.w_S.cross(p.I_C_S * m.w_S);
  } else {
    f = p.mass_kg * (g_S - m.a_S);
    t = c.cross(f);
  }
  Wrench w;
  w << f, t;
  return w;
}

Wrench pushWrench(const ContactSwitch& ct, const Mat3& R_BS, double t_s) {
  const Vec3 F_S = R_BS.transpose() * (ct.profile(t_s) * ct.force_B);
  Wrench w;
  w << F_S, ct.p_SP_S.cross(F_S);
  return w;
}

}  // namespace

Wrench CellSim::contactWrenchAt(const Mat3& R_BS, double t_s) const {
  Wrench w = Wrench::Zero();
  if (config_.contact.enabled) w += pushWrench(config_.contact, R_BS, t_s);
  for (const ContactSwitch& push : config_.pushes) w += pushWrench(push, R_BS, t_s);
  return w;
}

Wrench CellSim::loadWrenchFor(const model::SensorMotion& m, double t_s) const {
  const Vec3 g_S = m.R_BS.transpose() * g_B_;
  Wrench w = heldBodyWrench(config_.payload, m, g_S, config_.full_rigid_body);
  if (config_.payload_change.holds(t_s)) {
    w += heldBodyWrench(config_.payload_change.added, m, g_S, config_.full_rigid_body);
  }
  if (config_.cable.enabled) {
    const auto& cb = config_.cable;
    const Vec3 p_BA_attach_B = m.p_BS_B + m.R_BS * cb.p_SA_S;
    const Vec3 F_S = m.R_BS.transpose() * (cb.stiffness_N_per_m * (cb.p_BA_B - p_BA_attach_B));
    w.head<3>() += F_S;
    w.tail<3>() += cb.p_SA_S.cross(F_S);
  }
  if (hasContacts()) w += contactWrenchAt(m.R_BS, t_s);
  return w;
}

Wrench CellSim::offsetsAt(double t_s, double temp_degC) const {
  Wrench o;
  o << config_.F0_N, config_.T0_Nm;
  if (config_.temperature_drift.enabled) {
    const auto& d = config_.temperature_drift;
    const double dT = temp_degC - d.reference_degC;
    o.head<3>() += d.dF0_dT_N_per_degC * dT;
    o.tail<3>() += d.dT0_dT_Nm_per_degC * dT;
  }
  if (config_.time_drift.enabled) {
    o.head<3>() += config_.time_drift.dF0_dt_N_per_s * t_s;
    o.tail<3>() += config_.time_drift.dT0_dt_Nm_per_s * t_s;
  }
  return o;
}

SensorReading CellSim::readingAt(const JointVector& q, const JointVector& qd, const JointVector& qdd,
                                 double t_s, double temp_degC) const {
  SensorReading r;
  const model::SensorMotion m = config_.robot->computeSensorMotion(q, qd, qdd);
  const Vec3 g_S = m.R_BS.transpose() * g_B_;
  r.acc_S = m.a_S - g_S;  // = R_WS^T (a_W - g_W)
  r.w_S = m.w_S;
  r.alpha_S = m.alpha_S;
  r.temp_degC = temp_degC;
  const Wrench load = loadWrenchFor(m, t_s);
  if (hasContacts()) r.contact_S = contactWrenchAt(m.R_BS, t_s);
  Wrench sensed = load;
  if (config_.mounting.enabled) {
    // The sensor's true frame S' is rotated by R_SS' against the configured S: it reports in S'.
    const Mat3 Rt = config_.mounting.rotation().transpose();
    sensed << Rt * load.head<3>(), Rt * load.tail<3>();
    if (config_.mounting.rotate_imu) {
      r.acc_S = Rt * r.acc_S;
      r.w_S = Rt * r.w_S;
      r.alpha_S = Rt * r.alpha_S;
    }
  }
  if (config_.imu.enabled) {
    r.acc_S += config_.imu.acc_bias_mps2;  // the IMU's own errors, in its frame
    r.w_S += config_.imu.gyro_bias_radps;
  }
  r.wrench_S = config_.crosstalk.enabled ? Wrench((Mat6::Identity() + config_.crosstalk.E) * sensed) : sensed;
  r.wrench_S += offsetsAt(t_s, temp_degC);
  return r;
}

SensorReading CellSim::readingAt(const JointVector& q, const JointVector& qd, const JointVector& qdd,
                                 double t_s) const {
  return readingAt(q, qd, qdd, t_s, temperatureAt(t_s));
}

SensorReading CellSim::sampleAt(double t_s) const {
  const trajectory::TrajectoryPoint x = stateAt(t_s);
  SensorReading r = readingAt(x.q, x.qd, x.qdd, t_s);
  const double tau = sensorDelay();
  if (tau != 0.0) {
    // Exact delay (either sign): the wrench (and the contact truth that is part of it) is the full physical
    // reading of the instant t - tau, re-evaluated from the trajectory.
    const double td = t_s - tau;
    const trajectory::TrajectoryPoint xd = stateAt(td);
    const SensorReading rd = readingAt(xd.q, xd.qd, xd.qdd, td);
    r.wrench_S = rd.wrench_S;
    r.contact_S = rd.contact_S;
  }
  if (config_.imu.enabled && config_.imu.delay_s != 0.0) {
    // The IMU stream's own exact delay (either sign): the IMU reading of the instant t - delay.
    const double ti = t_s - config_.imu.delay_s;
    const trajectory::TrajectoryPoint xi = stateAt(ti);
    const SensorReading ri = readingAt(xi.q, xi.qd, xi.qdd, ti);
    r.acc_S = ri.acc_S;
    r.w_S = ri.w_S;
    r.alpha_S = ri.alpha_S;
  }
  return r;
}

void CellSim::addNoise(SensorReading& r, std::mt19937_64& rng) const {
  std::normal_distribution<double> n01(0.0, 1.0);
  const NoiseConfig& nz = config_.noise;
  const bool white = nz.wrench_lowpass_hz == 0.0 && nz.wrench_oversample == 1;
  for (int i = 0; i < 6; ++i) {
    const double e = n01(rng);  // always drawn: the draw order does not depend on the noise kind
    if (white) r.wrench_S[i] += nz.wrench_std[i] * e;
  }
  for (int i = 0; i < 3; ++i) r.acc_S[i] += nz.acc_std * n01(rng);
  for (int i = 0; i < 3; ++i) r.w_S[i] += nz.gyro_std * n01(rng);
  for (int i = 0; i < 3; ++i) r.alpha_S[i] += nz.alpha_std * n01(rng);
  r.temp_degC += nz.temp_std * n01(rng);
}

std::vector<Glitch> CellSim::glitches() const {
  std::vector<Glitch> out;
  if (!config_.glitches.enabled) return out;
  // Own stream: switching glitches on does not change the noise.
  std::mt19937_64 rng(config_.seed ^ 0x9E3779B97F4A7C15ULL);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const std::size_t n = sampleCount();
  for (std::size_t k = 0; k < n; ++k) {
    const double hit = u01(rng);
    const double which = u01(rng);
    const double sign = u01(rng) < 0.5 ? -1.0 : 1.0;
    if (hit >= config_.glitches.probability) continue;
    const int axis = std::min(5, static_cast<int>(which * 6.0));
    out.push_back({k, axis, sign * (axis < 3 ? config_.glitches.force_N : config_.glitches.torque_Nm)});
  }
  return out;
}

namespace {

/// Wrench noise of the logged samples: K sub-samples per sample, white or AR(1) (NoiseConfig).
class WrenchNoise {
 public:
  WrenchNoise(const NoiseConfig& nz, double rate_hz, std::uint64_t seed)
      : nz_(nz), rng_(seed ^ 0xD1B54A32D192ED03ULL) {
    const double sub_rate = rate_hz * nz.wrench_oversample;
    phi_ = nz.wrench_lowpass_hz > 0.0 ? std::exp(-2.0 * kPi * nz.wrench_lowpass_hz / sub_rate) : 0.0;
    std::normal_distribution<double> n01(0.0, 1.0);
    for (int i = 0; i < 6; ++i) state_[i] = n01(rng_);  // stationary start (unit marginal)
  }
  Wrench next() {
    std::normal_distribution<double> n01(0.0, 1.0);
    const double gain = std::sqrt(1.0 - phi_ * phi_);
    Wrench sum = Wrench::Zero();
    for (int j = 0; j < nz_.wrench_oversample; ++j) {
      for (int i = 0; i < 6; ++i) {
        state_[i] = phi_ * state_[i] + gain * n01(rng_);
        sum[i] += state_[i];
      }
    }
    return nz_.wrench_std.cwiseProduct(sum) / nz_.wrench_oversample;
  }

 private:
  const NoiseConfig& nz_;
  std::mt19937_64 rng_;
  double phi_ = 0.0;
  Wrench state_ = Wrench::Zero();
};

}  // namespace

namespace {

/// The compliant mount of MountDynamicsSwitch: state (y, y') per axis, advanced one sample at a time.
class MountResponse {
 public:
  MountResponse(const MountDynamicsSwitch& m, double rate_hz)
      : w_(2.0 * 3.141592653589793 * m.f_n_hz), zeta_(m.zeta), h_(1.0 / (rate_hz * kSubsteps)) {}

  /// The reading for the rigid wrench `u` of the next sample.
  Wrench next(const Wrench& u) {
    if (!started_) {
      y_ = u;
      u_last_ = u;
      started_ = true;
      return y_;
    }
    for (int i = 0; i < kSubsteps; ++i) {
      const Wrench u0 = u_last_ + (u - u_last_) * (static_cast<double>(i) / kSubsteps);
      const Wrench u1 = u_last_ + (u - u_last_) * (static_cast<double>(i + 1) / kSubsteps);
      rk4(u0, 0.5 * (u0 + u1), u1);
    }
    u_last_ = u;
    return y_;
  }

 private:
  static constexpr int kSubsteps = 16;
  Wrench accel(const Wrench& y, const Wrench& v, const Wrench& u) const {
    return w_ * w_ * (u - y) - 2.0 * zeta_ * w_ * v;
  }
  void rk4(const Wrench& u0, const Wrench& um, const Wrench& u1) {
    const Wrench a1 = accel(y_, v_, u0);
    const Wrench a2 = accel(y_ + 0.5 * h_ * v_, v_ + 0.5 * h_ * a1, um);
    const Wrench v2 = v_ + 0.5 * h_ * a1;
    const Wrench a3 = accel(y_ + 0.5 * h_ * v2, v_ + 0.5 * h_ * a2, um);
    const Wrench v3 = v_ + 0.5 * h_ * a2;
    const Wrench a4 = accel(y_ + h_ * v3, v_ + h_ * a3, u1);
    const Wrench v4 = v_ + h_ * a3;
    y_ += h_ / 6.0 * (v_ + 2.0 * v2 + 2.0 * v3 + v4);
    v_ += h_ / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4);
  }

  double w_, zeta_, h_;
  bool started_ = false;
  Wrench y_ = Wrench::Zero(), v_ = Wrench::Zero(), u_last_ = Wrench::Zero();
};

}  // namespace

logio::LogData CellSim::run() const {
  logio::LogData log;
  log.source = "<simulated>";
  log.has_wrench = true;
  log.has_imu = true;
  log.has_temp = true;
  const bool statics = config_.static_poses.enabled;
  const bool average = statics && config_.static_poses.average;
  const std::size_t per_row = average ? samplesPerHold() : 1;
  const std::size_t n_raw = statics ? static_cast<std::size_t>(config_.static_poses.poses) * samplesPerHold()
                                    : sampleCount();
  const std::size_t n = n_raw / per_row;
  log.samples.resize(n);
  const bool contact = hasContacts();
  if (contact) {
    for (int i = 0; i < 6; ++i) log.extra_names.push_back(std::string("contact_") + kWrenchAxisNames[i]);
    log.extra_columns.assign(6, std::vector<double>(n, 0.0));
  }
  const NoiseConfig& nz = config_.noise;
  const bool coloured = nz.wrench_lowpass_hz > 0.0 || nz.wrench_oversample > 1;
  const int K = nz.wrench_oversample;
  WrenchNoise wrench_noise(nz, config_.rate_hz, config_.seed);
  std::mt19937_64 rng(config_.seed);
  const std::vector<Glitch> spikes = glitches();
  std::size_t next_spike = 0;
  MountResponse mount(config_.mount_dynamics, config_.rate_hz);
  for (std::size_t row = 0; row < n; ++row) {
    logio::LogSample& s = log.samples[row];
    s = logio::LogSample{};
    Wrench contact_sum = Wrench::Zero();
    double t_sum = 0.0;
    for (std::size_t j = 0; j < per_row; ++j) {
      const std::size_t k = row * per_row + j;
      const double t = static_cast<double>(k) / config_.rate_hz;
      const trajectory::TrajectoryPoint x = stateAt(t);
      SensorReading r = sampleAt(t);
      if (K > 1) {
        // The sensor averages K sub-samples centred on t (signal and noise).
        Wrench sum = Wrench::Zero();
        for (int m = 0; m < K; ++m) {
          const double tm = t + (m - 0.5 * (K - 1)) / (K * config_.rate_hz);
          sum += sampleAt(tm).wrench_S;
        }
        r.wrench_S = sum / K;
      }
      if (config_.mount_dynamics.enabled) r.wrench_S = mount.next(r.wrench_S);  // a compliant mount (issue 22)
      addNoise(r, rng);
      if (coloured) r.wrench_S += wrench_noise.next();
      t_sum += t;
      s.q = x.q;
      s.qd = x.qd;
      s.qdd = x.qdd;
      s.wrench_S += r.wrench_S;
      s.acc_S += r.acc_S;
      s.w_S += r.w_S;
      s.alpha_S += r.alpha_S;
      s.temp_degC += r.temp_degC;
      contact_sum += r.contact_S;
    }
    const double inv = 1.0 / static_cast<double>(per_row);
    s.t = t_sum * inv;
    s.wrench_S *= inv;
    s.acc_S *= inv;
    s.w_S *= inv;
    s.alpha_S *= inv;
    s.temp_degC *= inv;
    while (next_spike < spikes.size() && spikes[next_spike].sample == row) {
      s.wrench_S[spikes[next_spike].axis] += spikes[next_spike].value;
      ++next_spike;
    }
    for (int a = 0; a < 6; ++a) {  // saturation (issue 22): the sensor's range clips the reading
      const double lim = config_.saturation.limit(a);
      if (lim > 0.0) s.wrench_S(a) = std::clamp(s.wrench_S(a), -lim, lim);
    }
    if (contact) {
      for (int i = 0; i < 6; ++i) log.extra_columns[static_cast<std::size_t>(i)][row] = contact_sum[i] * inv;
    }
  }
  return log;
}

void CellSim::setPayloadChangeTime(double t_s) {
  if (!std::isfinite(t_s)) throw ConfigError("payload change: the time must be finite");
  config_.payload_change.enabled = true;
  config_.payload_change.t_s = t_s;
}

void CellSim::setContactWindow(double t_start_s, double t_end_s) {
  if (!(t_end_s > t_start_s)) throw ConfigError("contact window: t_end must be after t_start");
  config_.contact.enabled = true;
  config_.contact.t_start_s = t_start_s;
  config_.contact.t_end_s = t_end_s;
}

}  // namespace ftid::sim
