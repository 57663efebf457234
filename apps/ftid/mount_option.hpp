#pragma once
// `--mount-rpy R,P,Y` and `--config FILE` of the offline commands (identify, analyze, compensate):
// the sensor mount X_FS of the contexts. The ftidd configuration's `sensor` mount when a config is
// given; --mount-rpy then sets the orientation R_FS = Rz(Y) Ry(P) Rx(R) [rad] (docs/conventions.md).
#include <iostream>
#include <string>

#include "command.hpp"
#include "ftid/common/error.hpp"
#include "ftid/config/daemon_config.hpp"
#include "ftid/identify/setup_check.hpp"
#include "ftid/samples/context.hpp"

namespace ftid::cli {

/// A config that cannot be loaded does not stop offline work (issue 26: only what a command needs
/// from it is read): the mount stays the identity (or --mount-rpy) and a warning on stderr says so.
inline void applyMount(samples::ContextOptions& context, const std::string& mount_rpy, const std::string& config_path) {
  if (!config_path.empty()) {
    try {
      const config::DaemonConfig cfg = config::loadDaemonConfig(config_path);
      context.R_FS = cfg.sensor.R_FS();
      context.p_FS_F = cfg.sensor.p_FS_F();
    } catch (const Error& e) {
      std::cerr << "ftid: WARNING: the sensor mount is not read from " << config_path << " (" << e.what()
                << "); the kinematics use " << (mount_rpy.empty() ? "the identity mount" : "--mount-rpy")
                << " (docs/operations.md \"Default files\")\n";
    }
  }
  if (!mount_rpy.empty()) {
    try {
      context.R_FS = identify::rotationFromRpy(identify::parseRpy(mount_rpy, "--mount-rpy"));
    } catch (const ConfigError& e) {
      throw UsageError(e.what());
    }
  }
}

}  // namespace ftid::cli
