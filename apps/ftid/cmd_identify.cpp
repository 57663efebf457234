// `ftid identify`: identify the payload parameters from a recorded log.
#include <iostream>

#include "command.hpp"
#include "input_flags.hpp"
#include "ftid/cell/exports.hpp"
#include "ftid/common/error.hpp"
#include "ftid/config/daemon_config.hpp"
#include "ftid/daemon/plausibility.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/identify/fit_check.hpp"
#include "ftid/identify/noise.hpp"
#include "ftid/identify/offline.hpp"
#include "ftid/identify/physical_check.hpp"
#include "mount_option.hpp"

namespace {

const char* const kUsage =
    "usage: ftid identify --log FILE [--method static|dynamic] [--model M] [--robot URDF]\n"
    "                     [--wrench-frame sensor|base] [--mount-rpy R,P,Y] [--noise fx=S,..,tz=S]\n"
    "                     [--wrench-log FILE [--wrench-time-offset S]] [--qdd-source diff|target]\n"
    "                     [--ur-payload M,CX,CY,CZ] [--imu on|off] [--rated-range fz=L,..]\n"
    "                     [--max-rows N]\n"
    "                     [--out PARAMS.yaml [--config ftidd.yaml]] [--json]\n"
    "\n"
    "Identifies the payload on the wrist force/torque sensor from a CSV log (docs/log-format.md).\n"
    "\n"
    "  --log FILE        the log (t, q, qd, qdd, fx..tz, ...; or the sensor pose instead of the joint\n"
    "                    angles: px,py,pz,qx,qy,qz,qw or rx,ry,rz, docs/log-format.md), or a UR RTDE\n"
    "                    recording (record.py, ur_rtde; recognised from its header: the wrench from\n"
    "                    actual_TCP_force in base axes unless --wrench-log is given), or a ROS 2 bag\n"
    "                    directory (rosbag2, sqlite3: --joint-topic, --wrench-topic)\n"
    "  --model M         the composed model to fit by weighted least squares (docs/effects.md);\n"
    "                    default 'paper+rigid_body', the model the cell (`ftid --identify`) uses; on a\n"
    "                    static log (the robot holds still: fewer than 100 moving samples) 'paper',\n"
    "                    as rotation terms need motion\n"
    "  --method M        the paper's own method instead of a model fit: 'dynamic' (with the inertial\n"
    "                    term -m a, for excitation runs) or 'static' (gravity only: rest poses or slow\n"
    "                    motion); `--method dynamic` reproduces the paper (and the old default)\n"
    "  --wrench-frame F  frame of the log's wrench columns: sensor (default) or base (rotated into\n"
    "                    the robot base B, moments about the S origin; docs/log-format.md)\n"
    "  --robot URDF      robot description (default: the shipped ur10.urdf, docs/operations.md)\n"
    "  --out FILE        write the parameter file (YAML, atomically; the previous one kept as .bak)\n"
    "                    and its exports beside it: FILE.ros2.yaml (ros2_control) and FILE.urscript\n"
    "                    (UR set_target_payload); docs/operations.md \"Exports\", `ftid export`\n"
    "  --config FILE     ftidd configuration for the plausibility limits (robot.rated_payload_kg, the\n"
    "                    sensor's rated range from its DBC) and the exports (sensor mount, `export:`\n"
    "                    section); default /etc/ftid/ftidd.yaml if it exists, else the shipped one.\n"
    "                    With --out, a set that is physically impossible or beyond the robot's\n"
    "                    payload or the sensor's range is not written: exit 1 with the reason.\n"
    "                    For the limits only those two keys are read; a file or key that cannot\n"
    "                    be read means the defaults (10 kg, the shipped DBC), and the limits used\n"
    "                    are printed on stderr (the exports then are not written, with a warning).\n"
    "                    Its sensor mount (X_FS) also builds the kinematics\n"
    "  --mount-rpy R,P,Y the sensor's orientation in the flange frame, R_FS = Rz(Y) Ry(P) Rx(R) [rad]\n"
    "                    (default: the --config file's sensor mount, else the identity), e.g.\n"
    "                    --mount-rpy 0,0,1.5708 for a sensor mounted turned 90 deg about z\n"
    "  --max-delay S     models with sensor_delay: search the delay in +-S seconds (default 1)\n"
    "  --imu on|off      the sensor's IMU (default: on when the log has the IMU columns ax..alz):\n"
    "                    its payload-free tilt (accelerometer and kinematics, with the accelerometer's\n"
    "                    bias), IMU frame and stream delay (gyro and kinematics, with the gyro's bias)\n"
    "                    are printed; with --model and `tilt` the IMU's tilt starts the tilt search and\n"
    "                    is fused with the wrench's information when the two agree. A disagreement on\n"
    "                    tilt, mount or delay beyond their uncertainties is a WARNING (a set-up error\n"
    "                    or a bad IMU). 'off': the wrench alone, exactly as without an IMU.\n"
    "                    docs/identification.md \"The IMU as a measurement\"\n"
    "%INPUT%"
    "%MAX_ROWS%"
    "  --json            print one JSON object instead of the table (keys: docs/identification.md)\n"
    "  --noise SPEC      the sensor's noise std per axis from its data sheet, e.g.\n"
    "                    fx=0.05,fy=0.05,fz=0.05,tx=0.01,ty=0.01,tz=0.01 [N, Nm] (default: estimated\n"
    "                    from the data: white, coloured or static pose set; docs/identification.md)\n"
    "  --rated-range fz=L,..\n"
    "                    the sensor's rated range per axis [N, Nm] (fx fy fz tx ty tz): samples with\n"
    "                    |reading| >= L are saturated. Flat tops (an axis piled up on its extreme\n"
    "                    value) are found without it. Saturated samples are left out of the fit and\n"
    "                    named in a warning and in the JSON's \"saturation\" (docs/analyze.md)\n"
    "\n"
    "Prints each parameter with its standard error (autocorrelation-robust: it holds for white and\n"
    "for low-pass filtered noise, docs/identification.md \"Uncertainty\"), the residual RMS per axis\n"
    "and the condition number, then checks the fit: the identification is repeated with each of 5 time blocks left\n"
    "out, and the held-out residual per axis is printed against the noise floor. Above 1.2x on any\n"
    "axis a warning says the model misses something and names the `ftid analyze` command.\n"
    "\n"
    "The line 'physical validity:' judges the result as `ftid analyze` does: the mass (positive, and\n"
    "determined: its standard error at most a third of it), the principal moments of the inertia about\n"
    "the centre of mass and the triangle inequalities (within 3 standard errors). A set that fails it is\n"
    "printed but never written or exported (no --out file, no .ros2.yaml, no .urscript): exit code 1.\n"
    "\n"
    "Exit code 1 with a one-line reason if the log is malformed, does not determine the parameters\n"
    "(the message names those not excited) or the result is not physically usable.\n"
    "\n"
    "Before the fit the set-up is checked against the kinematics (docs/identification.md \"Set-up\n"
    "diagnosis\"): a wrench frame that fits better as base, a mount that fits better rotated (the 24\n"
    "axis-aligned rotations), degrees in the angle columns. A finding is one line with the fix\n"
    "(--wrench-frame base, --mount-rpy R,P,Y); when another set-up explains the data, nothing is\n"
    "written (exit 1). The tilt search starts from the paper's force stage and from a level base and\n"
    "keeps the better minimum (a worse or undecided one is a warning). Glitches (isolated spikes\n"
    "beyond 6 robust standard deviations of a first fit's residual) are left out of the fit, as\n"
    "`ftid analyze` leaves them out.";

/// The usage with the shared recording options inserted.
const std::string& usage() {
  static const std::string text =
      ftid::cli::withMaxRowsHelp(ftid::cli::withInputFlagsHelp(kUsage), ftid::identify::kDefaultIdentifyMaxRows, "1 GB");
  return text;
}

int runIdentify(const std::vector<std::string>& argv) {
  ftid::identify::IdentifyRequest req;
  req.method.clear();
  std::string wrench_frame, out, config, noise, mount_rpy;
  bool json = false;
  std::string imu;
  CLI::App app{"ftid identify"};
  app.add_option("--log", req.log_path);
  app.add_option("--method", req.method)->transform(ftid::cli::oneOf({"static", "dynamic"}));
  app.add_option("--model", req.model);
  app.add_option("--robot", req.robot_urdf);
  app.add_option("--wrench-frame", wrench_frame)->transform(ftid::cli::oneOf({"sensor", "base"}));
  app.add_option("--out", out);
  app.add_option("--config", config);
  app.add_option("--mount-rpy", mount_rpy);
  app.add_flag("--json", json);
  app.add_option("--imu", imu)->transform(ftid::cli::oneOf({"on", "off"}));
  app.add_option("--noise", noise);
  std::string rated_range;  // saturation (issue 22)
  app.add_option("--rated-range", rated_range);
  app.add_option("--max-delay", req.max_delay_s)->transform(ftid::cli::real({0.0, 10.0, true, false}));
  ftid::cli::InputFlags input;
  ftid::cli::addInputFlags(app, input);
  std::size_t max_rows = ftid::identify::kDefaultIdentifyMaxRows;
  ftid::cli::addMaxRows(app, max_rows);
  ftid::cli::parse(app, argv);
  if (!req.method.empty() && !req.model.empty()) {
    throw ftid::cli::UsageError("give --model (a model fit) or --method (the paper's method), not both");
  }
  if (req.method.empty() && req.model.empty()) {
    req.model = ftid::identify::kDefaultModel;
    req.model_is_default = true;
  }
  ftid::cli::applyInputFlags(input, req.context.input);
  req.context.input.max_rows = max_rows;
  req.context.wrench_in_base = ftid::samples::parseWrenchFrame(wrench_frame);
  ftid::cli::applyMount(req.context, mount_rpy, config);
  if (!noise.empty()) {
    try {
      req.noise_std = ftid::identify::parseNoiseSpec(noise, "--noise");
    } catch (const ftid::ConfigError& e) {
      throw ftid::cli::UsageError(e.what());
    }
  }
  if (!rated_range.empty()) {  // saturation (issue 22)
    try {
      req.saturation.rated_range = ftid::identify::parseRatedRange(rated_range);
    } catch (const ftid::ConfigError& e) {
      throw ftid::cli::UsageError(e.what());
    }
  }
  using ImuUse = ftid::identify::IdentifyRequest::ImuUse;
  req.imu = imu.empty() ? ImuUse::kAuto : (imu == "on" ? ImuUse::kOn : ImuUse::kOff);
  if (req.log_path.empty()) throw ftid::cli::UsageError("--log FILE is required");
  if (!out.empty()) ftid::checkOutputPath(out);  // refuse a symlink/device/FIFO/directory before the work
  if (!json) req.progress = [](const std::string& line) { std::cerr << "ftid identify: " << line << "\n"; };
  ftid::identify::CheckedIdentification id = ftid::identify::identifyLogFileChecked(req);
  if (id.setup.explains) {
    // A set-up error explains the data better than the set-up as given: nothing is written.
    if (!json) std::cout << ftid::identify::formatParameterTable(id.set) << ftid::identify::formatFitCheck(id.check);
    throw ftid::IdentificationError(id.setup.lines.back() + "; no parameter file or export written");
  }
  // An inertia estimate just outside the possible set (within its uncertainty) is reported and
  // written as the nearest possible one, and said so (params::projectInertiaWithinUncertainty).
  // Beyond that (too far, or standard errors too large against the tensor) nothing is changed and
  // `not_projected` says why.
  std::string not_projected;
  if (const std::string note = ftid::params::projectInertiaWithinUncertainty(&id.set, &not_projected); !note.empty()) {
    std::cerr << "ftid identify: note: " << note << "\n";
  }
  const ftid::params::ParameterSet& set = id.set;
  // Physical validity first: a set that fails it is printed (to see why) but never written or
  // exported (the parameter writer's own rule, params::findParameterProblem, and a determined mass).
  const ftid::identify::PhysicalValidity validity = ftid::identify::checkPhysicalValidity(set, id.varying_mass);
  std::string exports;
  if (!out.empty() && validity.valid) {
    // Plausibility (issue 26): nothing is written for a set the cell cannot carry.
    // Only the plausibility inputs are read from the config: a bad or absent one means defaults.
    if (config.empty()) {
      try {
        config = ftid::cell::defaultExportConfigPath();
      } catch (const ftid::ConfigError&) {  // none installed: the default limits (said in the note)
      }
    }
    const ftid::daemon::OfflineLimits limits = ftid::daemon::offlinePlausibilityLimits(config);
    std::cerr << "ftid identify: " << limits.note << "\n";
    if (const auto problem = ftid::params::findParameterProblem(set, limits.limits)) {
      throw ftid::IdentificationError(out + ": not written: '" + problem->key + "': " + problem->message +
                                      (not_projected.empty() ? "" : " (" + not_projected + ")"));
    }
    ftid::params::writeParameterFile(out, set);
    // The parameters are written; a failed export (the exports need the whole, valid config) is
    // named in the warning.
    try {
      if (config.empty()) throw ftid::ConfigError("no ftidd configuration found");
      const ftid::config::DaemonConfig cell_config = ftid::config::loadDaemonConfig(config);
      exports = ftid::cell::writeExports(set, cell_config, out + ".ros2.yaml", out + ".urscript");
    } catch (const std::exception& e) {
      std::cerr << "ftid identify: WARNING: exports not written: " << e.what() << "\n";
    }
  }
  if (json) {
    std::cout << ftid::identify::identificationJson(id, req.imu != ImuUse::kOff, validity) << "\n";
  } else {
    std::cout << ftid::identify::formatParameterTable(set);
    std::cout << validity.line << "\n";
    std::cout << ftid::identify::formatImuReport(id.imu);
    std::cout << ftid::identify::formatFitCheck(id.check);
    const bool two_clocks = !input.wrench_log.empty() || ftid::logio::isDirectory(req.log_path);
    if (const auto* delay = set.find("delay"); delay != nullptr && two_clocks) {
      const std::string sensor = input.wrench_log.empty() ? "the wrench topic" : input.wrench_log;
      std::cout << "clock offset: " << sensor << " lags the robot's recording by " << delay->value * 1e3
                << " ms (sensor_delay's delay; --wrench-time-offset " << -delay->value << " aligns them)\n";
    }
    if (!out.empty() && validity.valid) std::cout << "parameters written to " << out << "\n";
    if (!exports.empty()) std::cout << "exports: " << exports << "\n";
  }
  if (!validity.valid) {
    throw ftid::IdentificationError(ftid::identify::physicalRefusal(validity) +
                                    (not_projected.empty() ? "" : " (" + not_projected + ")"));
  }
  return 0;
}

ftid::cli::Registrar reg{{"identify", "identify payload parameters from a recorded log", usage(), &runIdentify}};

}  // namespace
