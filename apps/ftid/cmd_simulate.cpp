// `ftid simulate`: write a simulated measurement log (and its truth) from the cell simulator.
// Physics and switches: docs/simulator.md. Log format: docs/log-format.md.
#include <sys/stat.h>

#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "command.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/common/default_files.hpp"
#include "ftid/common/error.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/sim/cell_sim.hpp"
#include "ftid/trajectory/trajectory_io.hpp"

namespace {

using ftid::cli::UsageError;

const char* kUsage = R"(usage: ftid simulate --out LOG.csv [options]

Simulates a UR arm moving a payload on a wrist F/T+IMU sensor and writes a measurement log
(docs/log-format.md) with first-principles rigid-body physics (docs/simulator.md). Defaults:
the paper's Table 2 payload, offsets and base tilt on a UR10, the paper-style 10 s, 5-harmonic,
0.1 Hz excitation of joints 4-6, 125 Hz, no hidden effects.

options:
  --out FILE             log to write (required; written atomically)
  --truth FILE           also write the true parameters and switches as YAML
  --robot URDF           robot description (default: the shipped ur10.urdf, docs/operations.md)
  --trajectory YAML      excitation trajectory file (ftid design output) instead of the
                         built-in paper-style trajectory
  --duration S           simulated time [s] (default: the trajectory's duration)
  --rate HZ              sample rate [Hz] (default 125)
  --seed N               noise seed (default 1); same seed -> identical log
  --noise-force N        white noise std of fx, fy, fz [N] (default 0.05)
  --noise-torque NM      white noise std of tx, ty, tz [Nm] (default 0.01)
  --noise-lowpass HZ     the wrench noise is 1st-order low-pass filtered at HZ (coloured, as
                         most sensors stream it; default 0 = white)
  --noise-oversample K   the sensor averages K sub-samples into each logged sample (signal and
                         noise; the logged noise std is then about the given std / sqrt(K))
  --noise-acc A          IMU accelerometer noise std [m/s^2] (default 0)
  --noise-gyro W         IMU angular velocity noise std [rad/s] (default 0)
  --noise-alpha AL       IMU angular acceleration noise std [rad/s^2] (default 0)
  --noise-temp T         temperature noise std [degC] (default 0)
  --mass KG              payload mass (default 8.862 N / g)
  --com X,Y,Z            centre of mass in S [m] (default 0.005,0.002,0.051)
  --inertia IXX,IYY,IZZ,IXY,IXZ,IYZ   inertia about the centre of mass, in S [kg m^2]
  --f0 X,Y,Z             force offsets [N]        --t0 X,Y,Z   torque offsets [Nm]
  --tilt-u-deg U         base tilt about x [deg]  --tilt-v-deg V  base tilt about y [deg]
  --mount-xyz X,Y,Z      sensor position in the flange frame [m] (default 0,0,0)
  --mount-rpy R,P,Y      sensor orientation in the flange frame, R_FS = Rz(Y) Ry(P) Rx(R) [rad]
  --static-poses N       a static pose set instead of the motion: N poses taken along the
                         trajectory, each held still for --hold S seconds (default 0.4)
  --average              with --static-poses: log one averaged reading per pose
  --paper-model          drop the rotational and lever-arm inertia terms (the paper's model only)
  --effect NAME[:key=value,...]   switch on a hidden effect (repeatable):
      cable              k=3 [N/m], anchor=X/Y/Z in B [m], attach=X/Y/Z in S [m]
      temperature_drift  df=X/Y/Z [N/degC], dt=X/Y/Z [Nm/degC], ref=25 [degC]
      time_drift         df=X/Y/Z [N/s], dt=X/Y/Z [Nm/s]
      sensor_delay       tau=0.012 [s] (exact shift; negative: the wrench leads)
      glitches           p=0.004 (per sample), force=10 [N], torque=1 [Nm]: isolated spikes
      mounting           roll=0, pitch=0, yaw=3 [deg]: the sensor is mounted rotated by
                         Rz(yaw) Ry(pitch) Rx(roll) against --mount-rpy and reports in its true frame
      crosstalk          scale=1 (multiplies the built-in 6x6 matrix E)
      contact            start=4, end=6 [s], force=X/Y/Z in B [N], point=X/Y/Z in S [m]
      rigid_body         full Newton-Euler (already the default; listed for symmetry)
    e.g. --effect sensor_delay:tau=0.02 --effect cable:k=5,anchor=-0.7/-0.3/1.4

examples:
  ftid simulate --out run.csv --truth truth.yaml --seed 7
  ftid simulate --out hidden.csv --effect temperature_drift --effect sensor_delay:tau=0.008
  ftid simulate --out real.csv --noise-lowpass 10 --effect glitches:p=0.004,force=10
  ftid simulate --out poses.csv --static-poses 100 --hold 0.5 --average

exit codes: 0 log written, 1 bad robot description or trajectory file (named), 2 usage error.)";

double parseDouble(const std::string& text, const std::string& what) {
  std::size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || !std::isfinite(v)) {
    throw UsageError(what + ": not a finite number: '" + text + "'");
  }
  return v;
}

std::vector<double> parseList(const std::string& text, char sep, const std::string& what) {
  std::vector<double> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, sep)) out.push_back(parseDouble(item, what));
  return out;
}

ftid::Vec3 parseVec3(const std::string& text, char sep, const std::string& what) {
  const auto v = parseList(text, sep, what);
  if (v.size() != 3) throw UsageError(what + ": expected 3 values, got '" + text + "'");
  return ftid::Vec3(v[0], v[1], v[2]);
}

// Vectors inside --effect use '/' between components (';' also accepted, but needs shell quoting).
ftid::Vec3 parseEffectVec3(std::string text, const std::string& what) {
  for (char& ch : text) {
    if (ch == ';') ch = '/';
  }
  return parseVec3(text, '/', what);
}

void applyEffect(const std::string& spec, ftid::sim::CellSimConfig& c) {
  const auto colon = spec.find(':');
  const std::string name = spec.substr(0, colon);
  std::vector<std::pair<std::string, std::string>> kv;
  if (colon != std::string::npos) {
    std::stringstream ss(spec.substr(colon + 1));
    std::string item;
    while (std::getline(ss, item, ',')) {
      const auto eq = item.find('=');
      if (eq == std::string::npos) throw UsageError("--effect " + name + ": expected key=value, got '" + item + "'");
      kv.emplace_back(item.substr(0, eq), item.substr(eq + 1));
    }
  }
  auto bad = [&](const std::string& key) {
    return UsageError("--effect " + name + ": unknown key '" + key + "' (see ftid simulate --help)");
  };
  const std::string w = "--effect " + name;
  if (name == "cable") {
    c.cable.enabled = true;
    for (const auto& [k, v] : kv) {
      if (k == "k") c.cable.stiffness_N_per_m = parseDouble(v, w + " k");
      else if (k == "anchor") c.cable.p_BA_B = parseEffectVec3(v, w + " anchor");
      else if (k == "attach") c.cable.p_SA_S = parseEffectVec3(v, w + " attach");
      else throw bad(k);
    }
  } else if (name == "temperature_drift") {
    c.temperature_drift.enabled = true;
    for (const auto& [k, v] : kv) {
      if (k == "df") c.temperature_drift.dF0_dT_N_per_degC = parseEffectVec3(v, w + " df");
      else if (k == "dt") c.temperature_drift.dT0_dT_Nm_per_degC = parseEffectVec3(v, w + " dt");
      else if (k == "ref") c.temperature_drift.reference_degC = parseDouble(v, w + " ref");
      else throw bad(k);
    }
  } else if (name == "time_drift") {
    c.time_drift.enabled = true;
    for (const auto& [k, v] : kv) {
      if (k == "df") c.time_drift.dF0_dt_N_per_s = parseEffectVec3(v, w + " df");
      else if (k == "dt") c.time_drift.dT0_dt_Nm_per_s = parseEffectVec3(v, w + " dt");
      else throw bad(k);
    }
  } else if (name == "sensor_delay") {
    c.sensor_delay.enabled = true;
    for (const auto& [k, v] : kv) {
      if (k == "tau") c.sensor_delay.tau_s = parseDouble(v, w + " tau");
      else throw bad(k);
    }
  } else if (name == "crosstalk") {
    c.crosstalk.enabled = true;
    for (const auto& [k, v] : kv) {
      if (k == "scale") c.crosstalk.E *= parseDouble(v, w + " scale");
      else throw bad(k);
    }
  } else if (name == "contact") {
    c.contact.enabled = true;
    for (const auto& [k, v] : kv) {
      if (k == "start") c.contact.t_start_s = parseDouble(v, w + " start");
      else if (k == "end") c.contact.t_end_s = parseDouble(v, w + " end");
      else if (k == "force") c.contact.force_B = parseEffectVec3(v, w + " force");
      else if (k == "point") c.contact.p_SP_S = parseEffectVec3(v, w + " point");
      else throw bad(k);
    }
  } else if (name == "glitches") {
    c.glitches.enabled = true;
    for (const auto& [k, v] : kv) {
      if (k == "p") c.glitches.probability = parseDouble(v, w + " p");
      else if (k == "force") c.glitches.force_N = parseDouble(v, w + " force");
      else if (k == "torque") c.glitches.torque_Nm = parseDouble(v, w + " torque");
      else throw bad(k);
    }
  } else if (name == "mounting") {
    c.mounting.enabled = true;
    constexpr double kDeg = 3.141592653589793 / 180.0;
    ftid::Vec3 rpy_deg(0.0, 0.0, 3.0);
    for (const auto& [k, v] : kv) {
      if (k == "roll") rpy_deg.x() = parseDouble(v, w + " roll");
      else if (k == "pitch") rpy_deg.y() = parseDouble(v, w + " pitch");
      else if (k == "yaw") rpy_deg.z() = parseDouble(v, w + " yaw");
      else throw bad(k);
    }
    c.mounting.rpy_rad = rpy_deg * kDeg;
  } else if (name == "rigid_body") {
    if (!kv.empty()) throw bad(kv.front().first);
    c.full_rigid_body = true;
  } else {
    throw UsageError("unknown effect '" + name +
                     "' (cable, temperature_drift, time_drift, sensor_delay, crosstalk, contact, glitches, mounting, "
                     "rigid_body)");
  }
}


int runSimulate(const std::vector<std::string>& argv) {
  using namespace ftid;
  cli::Args args(argv, kUsage);
  const std::string out = args.value("--out");
  const std::string truth = args.value("--truth");
  std::string robot_path = args.value("--robot");
  const std::string traj_path = args.value("--trajectory");
  const std::string duration = args.value("--duration");
  const std::string rate = args.value("--rate", "125");
  const std::string seed = args.value("--seed", "1");
  const double noise_f = parseDouble(args.value("--noise-force", "0.05"), "--noise-force");
  const double noise_t = parseDouble(args.value("--noise-torque", "0.01"), "--noise-torque");
  const double noise_lowpass = parseDouble(args.value("--noise-lowpass", "0"), "--noise-lowpass");
  const double noise_oversample = parseDouble(args.value("--noise-oversample", "1"), "--noise-oversample");
  const std::string static_poses = args.value("--static-poses");
  const double hold = parseDouble(args.value("--hold", "0.4"), "--hold");
  const bool average = args.flag("--average");
  const double noise_acc = parseDouble(args.value("--noise-acc", "0"), "--noise-acc");
  const double noise_gyro = parseDouble(args.value("--noise-gyro", "0"), "--noise-gyro");
  const double noise_alpha = parseDouble(args.value("--noise-alpha", "0"), "--noise-alpha");
  const double noise_temp = parseDouble(args.value("--noise-temp", "0"), "--noise-temp");
  const std::string mass = args.value("--mass"), com = args.value("--com"), inertia = args.value("--inertia");
  const std::string f0 = args.value("--f0"), t0 = args.value("--t0");
  const std::string tilt_u = args.value("--tilt-u-deg"), tilt_v = args.value("--tilt-v-deg");
  const std::string mount_xyz = args.value("--mount-xyz"), mount_rpy = args.value("--mount-rpy");
  const bool paper_model = args.flag("--paper-model");
  std::vector<std::string> effects;
  while (true) {
    const std::string e = args.value("--effect");
    if (e.empty()) break;
    effects.push_back(e);
  }
  args.finish();
  if (out.empty()) throw UsageError("--out is required");
  checkOutputPath(out);  // refuse a symlink/device/FIFO/directory before the work
  if (!truth.empty()) checkOutputPath(truth);

  if (robot_path.empty()) {
    robot_path = ftid::findDefaultFile("ur10.urdf");
  }
  sim::CellSimConfig c = sim::paperCellConfig(model::RobotKinematics::fromUrdfFile(robot_path));
  if (!traj_path.empty()) c.trajectory = trajectory::readTrajectoryFile(traj_path).toTrajectory();
  c.duration_s = duration.empty() ? c.trajectory.duration() : parseDouble(duration, "--duration");
  c.rate_hz = parseDouble(rate, "--rate");
  {
    std::size_t used = 0;
    unsigned long long s = 0;
    try {
      s = std::stoull(seed, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != seed.size()) throw UsageError("--seed: not a non-negative integer: '" + seed + "'");
    c.seed = s;
  }
  c.noise.wrench_std << noise_f, noise_f, noise_f, noise_t, noise_t, noise_t;
  c.noise.wrench_lowpass_hz = noise_lowpass;
  if (noise_oversample != std::floor(noise_oversample) || noise_oversample < 1 || noise_oversample > 1000) {
    throw UsageError("--noise-oversample: an integer 1..1000, got " + std::to_string(noise_oversample));
  }
  c.noise.wrench_oversample = static_cast<int>(noise_oversample);
  if (!static_poses.empty()) {
    const double np = parseDouble(static_poses, "--static-poses");
    if (np != std::floor(np) || np < 1 || np > 1e6) throw UsageError("--static-poses: an integer 1..1e6");
    c.static_poses.enabled = true;
    c.static_poses.poses = static_cast<int>(np);
    c.static_poses.hold_s = hold;
    c.static_poses.average = average;
    c.static_poses.span_s = c.duration_s;
    c.duration_s = np * hold;
  } else if (average) {
    throw UsageError("--average needs --static-poses");
  }
  c.noise.acc_std = noise_acc;
  c.noise.gyro_std = noise_gyro;
  c.noise.alpha_std = noise_alpha;
  c.noise.temp_std = noise_temp;
  if (!mass.empty()) c.payload.mass_kg = parseDouble(mass, "--mass");
  if (!com.empty()) c.payload.p_SC_S = parseVec3(com, ',', "--com");
  if (!inertia.empty()) {
    const auto v = parseList(inertia, ',', "--inertia");
    if (v.size() != 6) throw UsageError("--inertia: expected IXX,IYY,IZZ,IXY,IXZ,IYZ");
    c.payload.I_C_S << v[0], v[3], v[4], v[3], v[1], v[5], v[4], v[5], v[2];
  }
  if (!f0.empty()) c.F0_N = parseVec3(f0, ',', "--f0");
  if (!t0.empty()) c.T0_Nm = parseVec3(t0, ',', "--t0");
  constexpr double kDeg = 3.141592653589793 / 180.0;
  if (!tilt_u.empty()) c.tilt_u_rad = parseDouble(tilt_u, "--tilt-u-deg") * kDeg;
  if (!tilt_v.empty()) c.tilt_v_rad = parseDouble(tilt_v, "--tilt-v-deg") * kDeg;
  if (!mount_xyz.empty()) c.p_FS_F = parseVec3(mount_xyz, ',', "--mount-xyz");
  if (!mount_rpy.empty()) {
    const Vec3 rpy = parseVec3(mount_rpy, ',', "--mount-rpy");
    c.R_FS = (Eigen::AngleAxisd(rpy.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(rpy.y(), Vec3::UnitY()) *
              Eigen::AngleAxisd(rpy.x(), Vec3::UnitX()))
                 .toRotationMatrix();
  }
  if (paper_model) c.full_rigid_body = false;
  for (const auto& e : effects) applyEffect(e, c);

  const sim::CellSim simulator(c);
  logio::LogData log = simulator.run();
  log.source = out;
  logio::writeLog(out, log);
  if (!truth.empty()) sim::writeTruthYaml(truth, simulator.config());
  std::string on;
  for (const auto& e : effects) on += (on.empty() ? "" : ", ") + e.substr(0, e.find(':'));
  std::fprintf(stderr, "ftid simulate: %zu samples (%.3g s at %.6g Hz, seed %llu%s%s) -> %s%s%s\n",
               log.samples.size(), c.duration_s, c.rate_hz, static_cast<unsigned long long>(c.seed),
               on.empty() ? "" : ", effects: ", on.c_str(), out.c_str(), truth.empty() ? "" : ", truth -> ",
               truth.c_str());
  return 0;
}

}  // namespace

static ftid::cli::Registrar reg{{"simulate", "simulate a payload excitation run and write a log", kUsage,
                                 &runSimulate}};
