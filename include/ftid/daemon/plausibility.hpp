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

/// Throws ConfigError "SOURCE: key 'K': reason" if `set` (read from `source`) is physically
/// impossible or beyond the limits (params::findParameterProblem(set, limits)).
void requirePlausible(const params::ParameterSet& set, const params::PlausibilityLimits& limits,
                      const std::string& source);

}  // namespace ftid::daemon
