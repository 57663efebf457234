// `ftid identify`: identify the payload parameters from a recorded log.
#include <iostream>

#include "command.hpp"
#include "ftid/cell/exports.hpp"
#include "ftid/common/error.hpp"
#include "ftid/config/daemon_config.hpp"
#include "ftid/daemon/plausibility.hpp"
#include "ftid/fileio/atomic_file.hpp"
#include "ftid/identify/fit_check.hpp"
#include "ftid/identify/noise.hpp"
#include "ftid/identify/offline.hpp"

namespace {

const char* const kUsage =
    "usage: ftid identify --log FILE [--method static|dynamic] [--model M] [--robot URDF]\n"
    "                     [--wrench-frame sensor|base] [--noise fx=S,..,tz=S]\n"
    "                     [--out PARAMS.yaml [--config ftidd.yaml]] [--json]\n"
    "\n"
    "Identifies the payload on the wrist force/torque sensor from a CSV log (docs/log-format.md).\n"
    "\n"
    "  --log FILE        the log (t, q, qd, qdd, fx..tz, ...; or the sensor pose instead of the joint\n"
    "                    angles: px,py,pz,qx,qy,qz,qw or rx,ry,rz, docs/log-format.md)\n"
    "  --method M        the paper's method: 'dynamic' (default; with the inertial term -m a, for\n"
    "                    excitation runs) or 'static' (gravity only: rest poses or slow motion)\n"
    "  --model M         instead of the paper's method, fit a composed model by weighted least\n"
    "                    squares, e.g. 'paper' or 'paper+rigid_body' (docs/effects.md)\n"
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
    "                    are printed on stderr (the exports then are not written, with a warning)\n"
    "  --max-delay S     models with sensor_delay: search the delay in +-S seconds (default 1)\n"
    "  --json            print one JSON object instead of the table (keys: docs/identification.md)\n"
    "  --noise SPEC      the sensor's noise std per axis from its data sheet, e.g.\n"
    "                    fx=0.05,fy=0.05,fz=0.05,tx=0.01,ty=0.01,tz=0.01 [N, Nm] (default: estimated\n"
    "                    from the data: white, coloured or static pose set; docs/identification.md)\n"
    "\n"
    "Prints each parameter with its standard error (autocorrelation-robust: it holds for white and\n"
    "for low-pass filtered noise, docs/identification.md \"Uncertainty\"), the residual RMS per axis\n"
    "and the condition number, then checks the fit: the identification is repeated with each of 5 time blocks left\n"
    "out, and the held-out residual per axis is printed against the noise floor. Above 1.2x on any\n"
    "axis a warning says the model misses something and names the `ftid analyze` command. Exit code 1 with a one-line reason if the log is malformed or does not determine the\n"
    "parameters (the message names those not excited).";

int runIdentify(const std::vector<std::string>& argv) {
  ftid::identify::IdentifyRequest req;
  req.method = "dynamic";
  std::string wrench_frame, out, config, noise;
  bool json = false;
  CLI::App app{"ftid identify"};
  app.add_option("--log", req.log_path);
  app.add_option("--method", req.method)->transform(ftid::cli::oneOf({"static", "dynamic"}));
  app.add_option("--model", req.model);
  app.add_option("--robot", req.robot_urdf);
  app.add_option("--wrench-frame", wrench_frame)->transform(ftid::cli::oneOf({"sensor", "base"}));
  app.add_option("--out", out);
  app.add_option("--config", config);
  app.add_flag("--json", json);
  app.add_option("--noise", noise);
  app.add_option("--max-delay", req.max_delay_s)->transform(ftid::cli::real({0.0, 10.0, true, false}));
  ftid::cli::parse(app, argv);
  req.context.wrench_in_base = ftid::samples::parseWrenchFrame(wrench_frame);
  if (!noise.empty()) {
    try {
      req.noise_std = ftid::identify::parseNoiseSpec(noise, "--noise");
    } catch (const ftid::ConfigError& e) {
      throw ftid::cli::UsageError(e.what());
    }
  }
  if (req.log_path.empty()) throw ftid::cli::UsageError("--log FILE is required");
  if (!out.empty()) ftid::checkOutputPath(out);  // refuse a symlink/device/FIFO/directory before the work
  if (!json) req.progress = [](const std::string& line) { std::cerr << "ftid identify: " << line << "\n"; };
  const ftid::identify::CheckedIdentification id = ftid::identify::identifyLogFileChecked(req);
  ftid::params::ParameterSet set = id.set;
  std::string exports;
  if (!out.empty()) {
    // An inertia estimate just outside the possible set (within 3 standard errors) is written as
    // the nearest possible one, and said so; beyond that, or implausible: nothing is written.
    std::string not_projected;
    if (const std::string note = ftid::params::projectInertiaWithinUncertainty(&set, &not_projected); !note.empty()) {
      std::cerr << "ftid identify: note: " << note << "\n";
    }
    // Plausibility first (issue 26): nothing is written for a set the cell cannot carry.
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
    std::cout << ftid::identify::identificationJson(set, id.check) << "\n";
  } else {
    std::cout << ftid::identify::formatParameterTable(set);
    std::cout << ftid::identify::formatFitCheck(id.check);
    if (!out.empty()) std::cout << "parameters written to " << out << "\n";
    if (!exports.empty()) std::cout << "exports: " << exports << "\n";
  }
  return 0;
}

ftid::cli::Registrar reg{{"identify", "identify payload parameters from a recorded log", kUsage, &runIdentify}};

}  // namespace
