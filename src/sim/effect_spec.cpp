// `NAME[:key=value,...]` hidden-effect switches of the simulator (effect_spec.hpp).
#include "ftid/sim/effect_spec.hpp"

#include <cmath>
#include <cstdlib>
#include <sstream>
#include <utility>
#include <vector>

#include "ftid/common/error.hpp"
#include "ftid/sim/scenarios.hpp"

namespace ftid::sim {

namespace {

double number(const std::string& text, const std::string& what) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(v) || text.front() == ' ') {
    throw ConfigError(what + ": not a finite number: '" + text + "'");
  }
  return v;
}

Vec3 vector3(std::string text, const std::string& what) {
  for (char& ch : text) {
    if (ch == ';') ch = '/';
  }
  std::vector<double> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, '/')) v.push_back(number(item, what));
  if (v.size() != 3 || (!text.empty() && text.back() == '/')) {
    throw ConfigError(what + ": expected 3 values separated by '/', got '" + text + "'");
  }
  return Vec3(v[0], v[1], v[2]);
}

}  // namespace

void applyEffectSpec(const std::string& spec, CellSimConfig& c) {
  const auto colon = spec.find(':');
  const std::string name = spec.substr(0, colon);
  std::vector<std::pair<std::string, std::string>> kv;
  if (colon != std::string::npos) {
    std::stringstream ss(spec.substr(colon + 1));
    std::string item;
    while (std::getline(ss, item, ',')) {
      const auto eq = item.find('=');
      if (eq == std::string::npos) throw ConfigError("--effect " + name + ": expected key=value, got '" + item + "'");
      kv.emplace_back(item.substr(0, eq), item.substr(eq + 1));
    }
  }
  auto bad = [&](const std::string& key) {
    return ConfigError("--effect " + name + ": unknown key '" + key + "' (see ftid simulate --help)");
  };
  const std::string w = "--effect " + name;
  if (name == "cable") {
    c.cable.enabled = true;
    for (const auto& [k, v] : kv) {
      if (k == "k") c.cable.stiffness_N_per_m = number(v, w + " k");
      else if (k == "anchor") c.cable.p_BA_B = vector3(v, w + " anchor");
      else if (k == "attach") c.cable.p_SA_S = vector3(v, w + " attach");
      else throw bad(k);
    }
  } else if (name == "temperature_drift") {
    c.temperature_drift.enabled = true;
    for (const auto& [k, v] : kv) {
      if (k == "df") c.temperature_drift.dF0_dT_N_per_degC = vector3(v, w + " df");
      else if (k == "dt") c.temperature_drift.dT0_dT_Nm_per_degC = vector3(v, w + " dt");
      else if (k == "ref") c.temperature_drift.reference_degC = number(v, w + " ref");
      else throw bad(k);
    }
  } else if (name == "time_drift") {
    c.time_drift.enabled = true;
    for (const auto& [k, v] : kv) {
      if (k == "df") c.time_drift.dF0_dt_N_per_s = vector3(v, w + " df");
      else if (k == "dt") c.time_drift.dT0_dt_Nm_per_s = vector3(v, w + " dt");
      else throw bad(k);
    }
  } else if (name == "sensor_delay") {
    c.sensor_delay.enabled = true;
    for (const auto& [k, v] : kv) {
      if (k == "tau") c.sensor_delay.tau_s = number(v, w + " tau");
      else throw bad(k);
    }
  } else if (name == "crosstalk") {
    c.crosstalk.enabled = true;
    for (const auto& [k, v] : kv) {
      if (k == "scale") c.crosstalk.E *= number(v, w + " scale");
      else throw bad(k);
    }
  } else if (name == "contact") {
    c.contact.enabled = true;
    for (const auto& [k, v] : kv) {
      if (k == "start") c.contact.t_start_s = number(v, w + " start");
      else if (k == "end") c.contact.t_end_s = number(v, w + " end");
      else if (k == "force") c.contact.force_B = vector3(v, w + " force");
      else if (k == "point") c.contact.p_SP_S = vector3(v, w + " point");
      else throw bad(k);
    }
  } else if (name == "glitches") {
    c.glitches.enabled = true;
    for (const auto& [k, v] : kv) {
      if (k == "p") c.glitches.probability = number(v, w + " p");
      else if (k == "force") c.glitches.force_N = number(v, w + " force");
      else if (k == "torque") c.glitches.torque_Nm = number(v, w + " torque");
      else throw bad(k);
    }
  } else if (name == "mounting") {
    c.mounting.enabled = true;
    constexpr double kDeg = 3.141592653589793 / 180.0;
    Vec3 rpy_deg(0.0, 0.0, 3.0);
    for (const auto& [k, v] : kv) {
      if (k == "roll") rpy_deg.x() = number(v, w + " roll");
      else if (k == "pitch") rpy_deg.y() = number(v, w + " pitch");
      else if (k == "yaw") rpy_deg.z() = number(v, w + " yaw");
      else throw bad(k);
    }
    c.mounting.rpy_rad = rpy_deg * kDeg;
  } else if (name == "imu") {
    c.imu.enabled = true;
    for (const auto& [k, v] : kv) {
      if (k == "acc_bias") c.imu.acc_bias_mps2 = vector3(v, w + " acc_bias");
      else if (k == "gyro_bias") c.imu.gyro_bias_radps = vector3(v, w + " gyro_bias");
      else if (k == "delay") c.imu.delay_s = number(v, w + " delay");
      else throw bad(k);
    }
  } else if (name == "grasp") {
    c.payload_change.enabled = true;
    double mass = 0.6, side = 0.06;
    Vec3 com(0.0, 0.0, 0.12);
    for (const auto& [k, v] : kv) {
      if (k == "t") c.payload_change.t_s = number(v, w + " t");
      else if (k == "mass") mass = number(v, w + " mass");
      else if (k == "com") com = vector3(v, w + " com");
      else if (k == "side") side = number(v, w + " side");
      else throw bad(k);
    }
    if (!(mass >= 0.0) || !(side >= 0.0)) throw ConfigError(w + ": mass and side must be >= 0");
    c.payload_change.added = compactObject(mass, com, side);
  } else if (name == "pushes") {
    PushScenario sc;
    double seed = 1.0, until = 600.0;
    for (const auto& [k, v] : kv) {
      if (k == "seed") seed = number(v, w + " seed");
      else if (k == "force") sc.force_N = number(v, w + " force");
      else if (k == "min") sc.min_duration_s = number(v, w + " min");
      else if (k == "max") sc.max_duration_s = number(v, w + " max");
      else if (k == "gap_min") sc.min_gap_s = number(v, w + " gap_min");
      else if (k == "gap_max") sc.max_gap_s = number(v, w + " gap_max");
      else if (k == "until") until = number(v, w + " until");
      else throw bad(k);
    }
    if (!(seed >= 0.0 && seed == std::floor(seed) && seed < 1e15)) throw ConfigError(w + " seed: a whole number >= 0");
    if (!(sc.min_duration_s > 0.0 && sc.max_duration_s >= sc.min_duration_s && sc.min_gap_s > 0.0 &&
          sc.max_gap_s >= sc.min_gap_s && until > 0.0 && until <= 86400.0)) {
      throw ConfigError(w + ": needs 0 < min <= max, 0 < gap_min <= gap_max and 0 < until <= 86400");
    }
    const auto more = randomPushes(static_cast<std::uint64_t>(seed), 0.0, until, sc);
    c.pushes.insert(c.pushes.end(), more.begin(), more.end());
  } else if (name == "rigid_body") {
    if (!kv.empty()) throw bad(kv.front().first);
    c.full_rigid_body = true;
  } else {
    throw ConfigError("unknown effect '" + name +
                      "' (cable, temperature_drift, time_drift, sensor_delay, crosstalk, contact, glitches, mounting, "
                      "imu, rigid_body, grasp, pushes)");
  }
}

}  // namespace ftid::sim
