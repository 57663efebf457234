// `ftid identify`: identify the payload parameters from a recorded log.
#include <iostream>

#include "command.hpp"
#include "ftid/cell/exports.hpp"
#include "ftid/common/error.hpp"
#include "ftid/config/daemon_config.hpp"
#include "ftid/fileio/atomic_file.hpp"
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
    "  --config FILE     ftidd configuration for the exports (sensor mount, `export:` section;\n"
    "                    default /etc/ftid/ftidd.yaml if it exists, else the shipped ftidd.yaml)\n"
    "  --max-delay S     models with sensor_delay: search the delay in +-S seconds (default 1)\n"
    "  --json            print one JSON object instead of the table (keys: docs/identification.md)\n"
    "  --noise SPEC      the sensor's noise std per axis from its data sheet, e.g.\n"
    "                    fx=0.05,fy=0.05,fz=0.05,tx=0.01,ty=0.01,tz=0.01 [N, Nm] (default: estimated\n"
    "                    from the data: white, coloured or static pose set; docs/identification.md)\n"
    "\n"
    "Prints each parameter with its standard error, the residual RMS per axis and the condition\n"
    "number, then checks the fit: the identification is repeated with each of 5 time blocks left\n"
    "out, and the held-out residual per axis is printed against the noise floor. Above 1.2x on any\n"
    "axis a warning says the model misses something and names the `ftid analyze` command. Exit code 1 with a one-line reason if the log is malformed or does not determine the\n"
    "parameters (the message names those not excited).";

int runIdentify(const std::vector<std::string>& argv) {
  ftid::cli::Args args(argv, kUsage);
  ftid::identify::IdentifyRequest req;
  req.log_path = args.value("--log");
  req.method = args.value("--method", "dynamic");
  req.model = args.value("--model");
  req.robot_urdf = args.value("--robot");
  req.context.wrench_in_base = ftid::samples::parseWrenchFrame(args.value("--wrench-frame"));
  const std::string out = args.value("--out");
  std::string config = args.value("--config");
  const bool json = args.flag("--json");
  const std::string noise = args.value("--noise");
  const std::string max_delay = args.value("--max-delay");
  args.finish();
  if (!max_delay.empty()) {
    std::size_t used = 0;
    double d = 0.0;
    try {
      d = std::stod(max_delay, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != max_delay.size() || !(d > 0.0 && d <= 10.0)) {
      throw ftid::cli::UsageError("--max-delay must be a number of seconds in (0, 10], not '" + max_delay + "'");
    }
    req.max_delay_s = d;
  }
  if (!noise.empty()) {
    try {
      req.noise_std = ftid::identify::parseNoiseSpec(noise, "--noise");
    } catch (const ftid::ConfigError& e) {
      throw ftid::cli::UsageError(e.what());
    }
  }
  if (req.log_path.empty()) throw ftid::cli::UsageError("--log FILE is required");
  if (req.method != "static" && req.method != "dynamic") {
    throw ftid::cli::UsageError("--method must be 'static' or 'dynamic'");
  }
  if (!out.empty()) ftid::checkOutputPath(out);  // refuse a symlink/device/FIFO/directory before the work
  if (!json) req.progress = [](const std::string& line) { std::cerr << "ftid identify: " << line << "\n"; };
  const ftid::identify::CheckedIdentification id = ftid::identify::identifyLogFileChecked(req);
  const ftid::params::ParameterSet& set = id.set;
  std::string exports;
  if (!out.empty()) {
    ftid::params::writeParameterFile(out, set);
    // The parameters are written; a bad config only costs the exports (named in the warning).
    try {
      if (config.empty()) config = ftid::cell::defaultExportConfigPath();
      exports = ftid::cell::writeExports(set, ftid::config::loadDaemonConfig(config), out + ".ros2.yaml",
                                         out + ".urscript");
    } catch (const std::exception& e) {
      std::cerr << "ftid identify: WARNING: exports not written: " << e.what() << "\n";
    }
  }
  if (json) {
    std::string j = ftid::params::toJson(set);
    const auto close = j.rfind('}');
    j.insert(close, ", " + ftid::identify::fitCheckJsonMembers(id.check));
    std::cout << j << "\n";
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
