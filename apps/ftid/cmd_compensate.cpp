// `ftid compensate`: remove the identified payload wrench from a recorded log.
#include <cstdio>
#include <iostream>

#include "command.hpp"
#include "input_flags.hpp"
#include "ftid/cell/exports.hpp"
#include "ftid/common/error.hpp"
#include "ftid/compensate/compensate_log.hpp"
#include "ftid/config/daemon_config.hpp"
#include "ftid/daemon/plausibility.hpp"
#include "ftid/params/parameter_set.hpp"
#include "mount_option.hpp"

namespace {

const char* const kUsage =
    "usage: ftid compensate --log FILE --params PARAMS.yaml --out OUT.csv [--robot URDF]\n"
    "                       [--wrench-frame sensor|base] [--mount-rpy R,P,Y] [--config ftidd.yaml]\n"
    "                       [--wrench-log FILE] [--qdd-source diff|target] [--motion kinematics|imu]\n"
    "\n"
    "Computes, per sample, the contact wrench = reading - modelled wrench (offsets, gravity,\n"
    "inertia and every other effect of the parameter file's model) and writes OUT.csv with\n"
    "columns t, fx..tz (contact wrench, in S) and model_fx..model_tz (modelled wrench).\n"
    "Effects of an extra log column (payload(grip), poly(grip,1)) read it from --log, which must\n"
    "have it; ftidd has no extra columns and refuses such a parameter file (docs/effects.md).\n"
    "\n"
    "  --log FILE        the log or UR RTDE recording or ROS 2 bag (docs/log-format.md)\n"
    "  --params FILE     parameters written by `ftid identify --out`\n"
    "  --out FILE        the output CSV (written atomically)\n"
    "  --wrench-frame F  frame of the log's wrench columns: sensor (default) or base (rotated into\n"
    "                    the robot base B, moments about the S origin; docs/log-format.md)\n"
    "  --config FILE     ftidd configuration: its sensor mount (X_FS) builds the kinematics, and its\n"
    "                    plausibility limits: the robot's rated payload (robot.rated_payload_kg) and\n"
    "                    the sensor's rated range (the DBC's signal ranges); for the limits the\n"
    "                    default is /etc/ftid/ftidd.yaml if it exists, else the shipped ftidd.yaml;\n"
    "                    for the limits only those two keys are read, and a file or key that cannot\n"
    "                    be read means the defaults (10 kg; the shipped DBC's ranges), printed on\n"
    "                    stderr with their sources\n"
    "  --mount-rpy R,P,Y the sensor's orientation in the flange frame, R_FS = Rz(Y) Ry(P) Rx(R) [rad]\n"
    "                    (default: the --config file's sensor mount, else the identity), e.g.\n"
    "                    --mount-rpy 0,0,1.5708 for a sensor mounted turned 90 deg about z\n"
    "  --robot URDF      robot description (default: the shipped ur10.urdf, docs/operations.md)\n"
    "  --motion M        where the sensor's acceleration and angular motion come from: kinematics\n"
    "                    (default: the joints' q, qd, qdd through the robot model) or imu (the log's\n"
    "                    IMU columns ax..alz, less the parameter file's `imu` biases; for arms whose\n"
    "                    joint accelerations are poor or late; the orientation stays the kinematics').\n"
    "                    docs/effects.md \"Motion from the IMU\" measures the trade-off\n"
    "%INPUT%"
    "\n"
    "A parameter set that is physically impossible (whatever its standard errors) or beyond what\n"
    "the robot and sensor can carry is refused before anything is computed (docs/identification.md\n"
    "\"Plausibility\").\n"
    "\n"
    "Prints the RMS of the reading and of the contact wrench per axis. Exit: 0 written, 1 bad log\n"
    "or parameter file (the message names the file, line or key), 2 usage error.";

const std::string& usage() {
  static const std::string text = ftid::cli::withInputFlagsHelp(kUsage);
  return text;
}

int runCompensate(const std::vector<std::string>& argv) {
  ftid::compensate::CompensateRequest req;
  std::string wrench_frame, mount_rpy, config;
  CLI::App app{"ftid compensate"};
  app.add_option("--log", req.log_path);
  app.add_option("--params", req.params_path);
  app.add_option("--out", req.out_csv);
  app.add_option("--robot", req.robot_urdf);
  app.add_option("--wrench-frame", wrench_frame)->transform(ftid::cli::oneOf({"sensor", "base"}));
  app.add_option("--mount-rpy", mount_rpy);
  app.add_option("--config", config);
  std::string motion;
  app.add_option("--motion", motion)->transform(ftid::cli::oneOf({"kinematics", "imu"}));
  ftid::cli::InputFlags input;
  ftid::cli::addInputFlags(app, input);
  ftid::cli::parse(app, argv);
  ftid::cli::applyInputFlags(input, req.context.input);
  if (motion == "imu") req.motion = ftid::compensate::MotionSource::kImu;
  req.context.wrench_in_base = ftid::samples::parseWrenchFrame(wrench_frame);
  ftid::cli::applyMount(req.context, mount_rpy, config);
  if (req.log_path.empty() || req.params_path.empty() || req.out_csv.empty()) {
    throw ftid::cli::UsageError("--log, --params and --out are required");
  }
  if (config.empty()) {
    try {
      config = ftid::cell::defaultExportConfigPath();
    } catch (const ftid::ConfigError&) {  // none installed: the default limits (said in the note)
    }
  }
  // Only the plausibility inputs are read from the config; a bad or absent one means defaults.
  const ftid::daemon::OfflineLimits limits = ftid::daemon::offlinePlausibilityLimits(config);
  std::fprintf(stderr, "ftid compensate: %s\n", limits.note.c_str());
  const ftid::params::ParameterSet set = ftid::params::readParameterFile(req.params_path);
  ftid::daemon::requirePlausible(set, limits.limits, req.params_path);
  const auto s = ftid::compensate::compensateLogFile(req, set);  // the checked set, not a re-read
  std::printf("%d samples compensated -> %s\n", s.n_samples, req.out_csv.c_str());
  if (s.n_without_kinematics > 0) {
    std::printf("%d samples left out: with the identified sensor delay their kinematics lie outside the log\n",
                s.n_without_kinematics);
  }
  if (!s.time_note.empty()) std::fprintf(stderr, "warning: %s\n", s.time_note.c_str());
  if (!s.imu_note.empty()) std::fprintf(stderr, "warning: %s\n", s.imu_note.c_str());
  std::printf("%-6s %12s %12s\n", "axis", "raw RMS", "contact RMS");
  const char* axes[6] = {"fx", "fy", "fz", "tx", "ty", "tz"};
  for (int a = 0; a < 6; ++a) std::printf("%-6s %12.4g %12.4g\n", axes[a], s.raw_rms(a), s.contact_rms(a));
  return 0;
}

ftid::cli::Registrar reg{{"compensate", "remove the payload wrench from a log (contact wrench CSV)", usage(),
                          &runCompensate}};

}  // namespace
