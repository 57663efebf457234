// `ftid export`: the UR and ros2_control exports of a parameter file (docs/operations.md "Exports").
#include <iostream>

#include "command.hpp"
#include "ftid/cell/exports.hpp"
#include "ftid/config/daemon_config.hpp"
#include "ftid/params/parameter_set.hpp"

namespace {

const char* const kUsage =
    "usage: ftid export --params PARAMS.yaml [--ros2 OUT.yaml] [--urscript OUT.script]\n"
    "                   [--config ftidd.yaml]\n"
    "\n"
    "Writes the identified payload in the forms other tools read (docs/operations.md \"Exports\"):\n"
    "\n"
    "  --params FILE     parameter file (from `ftid identify --out` or `ftid --identify`)\n"
    "  --ros2 FILE       ros2_control parameters: force_torque_sensor_broadcaster with a\n"
    "                    control_filters/GravityCompensationWrench filter (tool.mass, tool.CoG in\n"
    "                    the sensor frame, tool.gravity_field in the base frame with the identified\n"
    "                    tilt) and the sensor offsets in its offset keys (offset = -F0, -T0)\n"
    "  --urscript FILE   UR set_target_payload(mass, cog, inertia) for everything beyond the flange:\n"
    "                    the payload plus the adapter and sensor body of the config's `export:`\n"
    "  --config FILE     ftidd configuration with the sensor mount, the `export:` frames and parts\n"
    "                    (default /etc/ftid/ftidd.yaml if it exists, else the shipped ftidd.yaml)\n"
    "\n"
    "Without --ros2 and --urscript, writes PARAMS.ros2.yaml and PARAMS.urscript beside the\n"
    "parameter file (the names `ftid identify --out` and `ftid --identify` use). Files are written\n"
    "atomically. Exit: 0 written, 1 bad parameter or config file (the message names it), 2 usage.";

int runExport(const std::vector<std::string>& argv) {
  std::string params, ros2, urscript, config;
  CLI::App app{"ftid export"};
  app.add_option("--params", params);
  app.add_option("--ros2", ros2);
  app.add_option("--urscript", urscript);
  app.add_option("--config", config);
  ftid::cli::parse(app, argv);
  if (params.empty()) throw ftid::cli::UsageError("--params FILE is required");
  if (ros2.empty() && urscript.empty()) {
    ros2 = params + ".ros2.yaml";
    urscript = params + ".urscript";
  }
  if (config.empty()) config = ftid::cell::defaultExportConfigPath();
  const ftid::params::ParameterSet set = ftid::params::readParameterFile(params);
  const ftid::config::DaemonConfig cfg = ftid::config::loadDaemonConfig(config);
  std::cout << "exports (config " << config << "): " << ftid::cell::writeExports(set, cfg, ros2, urscript) << "\n";
  return 0;
}

ftid::cli::Registrar reg{{"export", "write the UR and ros2_control exports of a parameter file", kUsage, &runExport}};

}  // namespace
