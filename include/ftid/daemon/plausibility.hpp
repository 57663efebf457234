#pragma once
// The plausibility limits of a parameter set (params::PlausibilityLimits) for a cell, from its
// ftidd configuration: the robot's rated payload (robot.rated_payload_kg) and the sensor's rated
// range (the [min|max] of the wrench signals in sensor.dbc_path). Used by ftidd (start, reload),
// `ftid compensate`, `ftid identify --out` and `ftid --identify` (issue 26).
#include "ftid/config/daemon_config.hpp"
#include "ftid/params/parameter_set.hpp"

namespace ftid::daemon {

/// Throws ConfigError naming the DBC if it cannot be read or lacks a wrench signal.
params::PlausibilityLimits plausibilityLimits(const config::DaemonConfig& config);

/// The checks of the sensor's description that ftidd's start and `ftidd --check-config` share:
/// sensor.dbc_path parses, gives the wrench signals' rated range (plausibilityLimits), and has the
/// IMU's signals when sensor.motion_source is imu (a sensor without them could never give a valid
/// cycle). Throws ConfigError naming the key and the file.
void checkSensorDescription(const config::DaemonConfig& config);

/// The limits for an offline command (`ftid compensate`, `ftid identify --out`): only the two
/// plausibility inputs are read from `config_path` (robot.rated_payload_kg, sensor.dbc_path; the
/// rest of ftidd.yaml is not validated, so a config with a problem elsewhere does not matter);
/// what cannot be read falls back to the defaults (10 kg; the shipped DBC, else no range limit).
/// Never throws for a bad or absent config; `note` says which limits were used and from where.
struct OfflineLimits {
  params::PlausibilityLimits limits;
  std::string note;
};
OfflineLimits offlinePlausibilityLimits(const std::string& config_path);

/// Throws ConfigError "SOURCE: key 'K': reason" if `set` (read from `source`) is physically
/// impossible or beyond the limits (params::findParameterProblem(set, limits)).
void requirePlausible(const params::ParameterSet& set, const params::PlausibilityLimits& limits,
                      const std::string& source);

}  // namespace ftid::daemon
