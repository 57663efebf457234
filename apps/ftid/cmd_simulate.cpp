// `ftid simulate`: write a simulated measurement log (and its truth) from the cell simulator.
// Physics and switches: docs/simulator.md. Log format: docs/log-format.md.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include "command.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/common/default_files.hpp"
#include "ftid/common/error.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/sim/cell_sim.hpp"
#include "ftid/sim/effect_spec.hpp"
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
      saturation         fz=120 (any of fx..tz) [N, Nm]: the sensor's range; a reading beyond
                         +-limit reads the limit (clipped after noise and glitches)
      mount_dynamics     f=3 [Hz], zeta=0.1: a compliant mount; the sensor reads the rigid wrench
                         through y'' + 2 zeta w y' + w^2 y = w^2 u (w = 2 pi f), before the noise
      mounting           roll=0, pitch=0, yaw=3 [deg]: the sensor is mounted rotated by
                         Rz(yaw) Ry(pitch) Rx(roll) against --mount-rpy and reports in its true frame
      crosstalk          scale=1 (multiplies the built-in 6x6 matrix E)
      imu                acc_bias=0.03/-0.02/0.04 [m/s^2], gyro_bias=0.002/-0.003/0.001 [rad/s],
                         delay=0 [s]: the IMU's biases and its own stream delay (exact shift)
      contact            start=4, end=6 [s], force=X/Y/Z in B [N], point=X/Y/Z in S [m]
      grasp              t=5 [s], mass=0.6 [kg], com=X/Y/Z in S [m] (0/0/0.12), side=0.06 [m]: an
                         object (a solid cube) is held from t on, on top of the payload
      release            the keys of grasp: the object is held from the start and let go at t
      pushes             seed=1, force=12 [N], min=0.4, max=0.6 [s], gap_min=1, gap_max=6 [s],
                         until=600 [s]: random pushes (direction uniform in B, sin^2 profile)
      rigid_body         full Newton-Euler (already the default; listed for symmetry)
    e.g. --effect sensor_delay:tau=0.02 --effect cable:k=5,anchor=-0.7/-0.3/1.4

examples:
  ftid simulate --out run.csv --truth truth.yaml --seed 7
  ftid simulate --out hidden.csv --effect temperature_drift --effect sensor_delay:tau=0.008
  ftid simulate --out real.csv --noise-lowpass 10 --effect glitches:p=0.004,force=10
  ftid simulate --out poses.csv --static-poses 100 --hold 0.5 --average

exit codes: 0 log written, 1 bad robot description or trajectory file (named), 2 usage error.)";

int runSimulate(const std::vector<std::string>& argv) {
  using namespace ftid;
  namespace cli = ftid::cli;
  std::string out, truth, robot_path, traj_path;
  double duration = 0.0, rate = 125.0, hold = 0.4;
  std::uint64_t seed = 1;
  double noise_f = 0.05, noise_t = 0.01, noise_lowpass = 0.0;
  int noise_oversample = 1, static_poses = 0;
  double noise_acc = 0.0, noise_gyro = 0.0, noise_alpha = 0.0, noise_temp = 0.0;
  double mass = 0.0, tilt_u_deg = 0.0, tilt_v_deg = 0.0;
  std::vector<double> com, inertia, f0, t0, mount_xyz, mount_rpy;
  bool average = false, paper_model = false;
  std::vector<std::string> effects;
  CLI::App app{"ftid simulate"};
  app.add_option("--out", out);
  app.add_option("--truth", truth);
  app.add_option("--robot", robot_path);
  app.add_option("--trajectory", traj_path);
  CLI::Option* duration_opt = app.add_option("--duration", duration)->transform(cli::real(cli::positive()));
  app.add_option("--rate", rate)->transform(cli::real(cli::positive()));
  app.add_option("--seed", seed)->transform(cli::count());
  app.add_option("--noise-force", noise_f)->transform(cli::real(cli::nonNegative()));
  app.add_option("--noise-torque", noise_t)->transform(cli::real(cli::nonNegative()));
  app.add_option("--noise-lowpass", noise_lowpass)->transform(cli::real(cli::nonNegative()));
  app.add_option("--noise-oversample", noise_oversample)->transform(cli::integer(1, 1000));
  app.add_option("--noise-acc", noise_acc)->transform(cli::real(cli::nonNegative()));
  app.add_option("--noise-gyro", noise_gyro)->transform(cli::real(cli::nonNegative()));
  app.add_option("--noise-alpha", noise_alpha)->transform(cli::real(cli::nonNegative()));
  app.add_option("--noise-temp", noise_temp)->transform(cli::real(cli::nonNegative()));
  CLI::Option* mass_opt = app.add_option("--mass", mass)->transform(cli::real());
  cli::addReals(app, "--com", com, 3);
  cli::addReals(app, "--inertia", inertia, 6);
  cli::addReals(app, "--f0", f0, 3);
  cli::addReals(app, "--t0", t0, 3);
  CLI::Option* tilt_u_opt = app.add_option("--tilt-u-deg", tilt_u_deg)->transform(cli::real());
  CLI::Option* tilt_v_opt = app.add_option("--tilt-v-deg", tilt_v_deg)->transform(cli::real());
  cli::addReals(app, "--mount-xyz", mount_xyz, 3);
  cli::addReals(app, "--mount-rpy", mount_rpy, 3);
  CLI::Option* poses_opt = app.add_option("--static-poses", static_poses)->transform(cli::integer(1, 1000000));
  app.add_option("--hold", hold)->transform(cli::real(cli::positive()));
  app.add_flag("--average", average);
  app.add_flag("--paper-model", paper_model);
  cli::addRepeatable(app, "--effect", effects);
  cli::parse(app, argv);
  if (out.empty()) throw UsageError("--out is required");
  {
    // Command-line mistakes before any file is read: try every --effect on a scratch configuration.
    sim::CellSimConfig scratch;
    for (const auto& e : effects) {
      try {
        sim::applyEffectSpec(e, scratch);
      } catch (const ConfigError& err) {
        throw UsageError(err.what());
      }
    }
  }
  checkOutputPath(out);  // refuse a symlink/device/FIFO/directory before the work
  if (!truth.empty()) checkOutputPath(truth);

  if (robot_path.empty()) {
    robot_path = ftid::findDefaultFile("ur10.urdf");
  }
  sim::CellSimConfig c = sim::paperCellConfig(model::RobotKinematics::fromUrdfFile(robot_path));
  if (!traj_path.empty()) c.trajectory = trajectory::readTrajectoryFile(traj_path).toTrajectory();
  c.duration_s = duration_opt->count() == 0 ? c.trajectory.duration() : duration;
  c.rate_hz = rate;
  c.seed = seed;
  c.noise.wrench_std << noise_f, noise_f, noise_f, noise_t, noise_t, noise_t;
  c.noise.wrench_lowpass_hz = noise_lowpass;
  c.noise.wrench_oversample = noise_oversample;
  if (poses_opt->count() > 0) {
    c.static_poses.enabled = true;
    c.static_poses.poses = static_poses;
    c.static_poses.hold_s = hold;
    c.static_poses.average = average;
    c.static_poses.span_s = c.duration_s;
    c.duration_s = static_poses * hold;
  } else if (average) {
    throw UsageError("--average needs --static-poses");
  }
  c.noise.acc_std = noise_acc;
  c.noise.gyro_std = noise_gyro;
  c.noise.alpha_std = noise_alpha;
  c.noise.temp_std = noise_temp;
  if (mass_opt->count() > 0) c.payload.mass_kg = mass;
  if (!com.empty()) c.payload.p_SC_S = Vec3(com[0], com[1], com[2]);
  if (!inertia.empty()) {
    const auto& v = inertia;
    c.payload.I_C_S << v[0], v[3], v[4], v[3], v[1], v[5], v[4], v[5], v[2];
  }
  if (!f0.empty()) c.F0_N = Vec3(f0[0], f0[1], f0[2]);
  if (!t0.empty()) c.T0_Nm = Vec3(t0[0], t0[1], t0[2]);
  constexpr double kDeg = 3.141592653589793 / 180.0;
  if (tilt_u_opt->count() > 0) c.tilt_u_rad = tilt_u_deg * kDeg;
  if (tilt_v_opt->count() > 0) c.tilt_v_rad = tilt_v_deg * kDeg;
  if (!mount_xyz.empty()) c.p_FS_F = Vec3(mount_xyz[0], mount_xyz[1], mount_xyz[2]);
  if (!mount_rpy.empty()) {
    const Vec3 rpy(mount_rpy[0], mount_rpy[1], mount_rpy[2]);
    c.R_FS = (Eigen::AngleAxisd(rpy.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(rpy.y(), Vec3::UnitY()) *
              Eigen::AngleAxisd(rpy.x(), Vec3::UnitX()))
                 .toRotationMatrix();
  }
  if (paper_model) c.full_rigid_body = false;
  for (const auto& e : effects) sim::applyEffectSpec(e, c);  // checked above

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
