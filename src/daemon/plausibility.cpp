#include "ftid/daemon/plausibility.hpp"

#include <filesystem>
#include <sstream>

#include "ftid/common/default_files.hpp"
#include "ftid/common/error.hpp"
#include "ftid/fileio/yaml_reader.hpp"
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

void checkSensorDescription(const config::DaemonConfig& config) {
  (void)plausibilityLimits(config);
  if (config.sensor.motion_source != "imu") return;
  bool has_imu = false;
  try {
    has_imu = drivers::can::SensorLayout::fromDbc(drivers::can::loadDbc(config.sensor.dbc_path)).hasImu();
  } catch (const Error& e) {
    throw ConfigError("key 'sensor.dbc_path': " + std::string(e.what()));
  }
  if (!has_imu) {
    throw ConfigError("sensor.motion_source: imu, but the sensor's DBC " + config.sensor.dbc_path +
                      " has no IMU signals (AccX..AngAccZ): use 'kinematics'");
  }
}

OfflineLimits offlinePlausibilityLimits(const std::string& config_path) {
  OfflineLimits out;
  params::PlausibilityLimits& limits = out.limits;
  std::string payload_why = "the built-in default";
  std::string dbc_path;
  std::string dbc_why;
  limits.max_payload_kg = config::RobotConfig().rated_payload_kg;
  try {
    if (config_path.empty()) throw ConfigError("no configuration found");
    const YamlFile file = YamlFile::load(config_path, "config file");
    const YamlValue root = file.root();
    const YamlValue payload = root["robot"]["rated_payload_kg"];
    if (payload.present()) {
      limits.max_payload_kg = payload.number(NumberRange{0.0, 1000.0, true, false, {}});
      payload_why = config_path + ": robot.rated_payload_kg";
    } else {
      payload_why = "the default (robot.rated_payload_kg not in " + config_path + ")";
    }
    const YamlValue dbc = root["sensor"]["dbc_path"];
    if (dbc.present()) {
      dbc_path = dbc.nonEmptyText();
      if (std::filesystem::path(dbc_path).is_relative()) {
        dbc_path = (std::filesystem::path(config_path).parent_path() / dbc_path).lexically_normal().string();
      }
      dbc_why = config_path + ": sensor.dbc_path";
    }
  } catch (const Error& e) {
    payload_why = std::string("the built-in default; the configuration was not usable: ") + e.what();
  }
  if (dbc_path.empty()) {
    try {
      dbc_path = findDefaultFile("ftsensor.dbc");
      dbc_why = "the shipped default";
    } catch (const Error&) {
      dbc_why = "none found";
    }
  }
  limits.payload_source = payload_why;
  std::string range_note = "none (no sensor description: " + dbc_why + ")";
  if (!dbc_path.empty()) {
    try {
      const drivers::can::DbcDatabase db = drivers::can::loadDbc(dbc_path);
      const std::array<double, 6> range = drivers::can::ratedWrenchRange(db);
      for (int a = 0; a < 6; ++a) limits.sensor_range(a) = range[static_cast<std::size_t>(a)];
      limits.range_source = "signal ranges in " + dbc_path + " (" + dbc_why + ")";
      range_note = limits.range_source;
    } catch (const Error& e) {
      range_note = std::string("none (") + dbc_path + " unusable: " + e.what() + ")";
    }
  }
  std::ostringstream os;
  os << "plausibility limits: rated payload " << limits.max_payload_kg << " kg (" << payload_why
     << "); sensor rated range: " << range_note;
  out.note = os.str();
  return out;
}

void requirePlausible(const params::ParameterSet& set, const params::PlausibilityLimits& limits,
                      const std::string& source) {
  if (const auto problem = params::findParameterProblem(set, limits)) {
    throw ConfigError(source + ": key '" + problem->key + "': " + problem->message);
  }
}

}  // namespace ftid::daemon
