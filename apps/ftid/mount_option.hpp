#pragma once
// `--mount-rpy R,P,Y` and `--config FILE` of the offline commands (identify, analyze, compensate):
// the sensor mount X_FS of the contexts. The ftidd configuration's `sensor` mount when a config is
// given; --mount-rpy then sets the orientation R_FS = Rz(Y) Ry(P) Rx(R) [rad] (docs/conventions.md).
#include <string>

#include "command.hpp"
#include "ftid/common/error.hpp"
#include "ftid/config/daemon_config.hpp"
#include "ftid/identify/setup_check.hpp"
#include "ftid/samples/context.hpp"

namespace ftid::cli {

inline void applyMount(samples::ContextOptions& context, const std::string& mount_rpy, const std::string& config_path) {
  if (!config_path.empty()) {
    const config::DaemonConfig cfg = config::loadDaemonConfig(config_path);
    context.R_FS = cfg.sensor.R_FS();
    context.p_FS_F = cfg.sensor.p_FS_F();
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
