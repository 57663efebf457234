#include "ftid/daemon/plausibility.hpp"

#include "ftid/common/error.hpp"
#include "ftid/drivers/can/dbc.hpp"
#include "ftid/drivers/can/sensor_layout.hpp"

namespace ftid::daemon {

params::PlausibilityLimits plausibilityLimits(const config::DaemonConfig& config) {
  params::PlausibilityLimits limits;
  const std::string cfg = config.source.empty() ? std::string("built-in default") : config.source;
  limits.max_payload_kg = config.robot.rated_payload_kg;
  limits.payload_source = cfg + ": robot.rated_payload_kg";
  try {
    const drivers::can::DbcDatabase dbc = drivers::can::loadDbc(config.sensor.dbc_path);
    const std::array<double, 6> range = drivers::can::ratedWrenchRange(dbc);
    for (int a = 0; a < 6; ++a) limits.sensor_range(a) = range[static_cast<std::size_t>(a)];
  } catch (const Error& e) {
    throw ConfigError(cfg + ": key 'sensor.dbc_path': the sensor's rated range is unknown: " + e.what());
  }
  limits.range_source = "signal ranges in " + config.sensor.dbc_path;
  return limits;
}

void requirePlausible(const params::ParameterSet& set, const params::PlausibilityLimits& limits,
                      const std::string& source) {
  if (const auto problem = params::findParameterProblem(set, limits)) {
    throw ConfigError(source + ": key '" + problem->key + "': " + problem->message);
  }
}

}  // namespace ftid::daemon
