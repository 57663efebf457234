// `NAME[:key=value,...]` hidden-effect switches of the simulator (effect_spec.hpp).
#include "ftid/sim/effect_spec.hpp"

#include <array>
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

/// One `--effect NAME[:key=value,...]` switch: the effect's name and its keys in the given order.
struct EffectArgs {
  std::string name;
  std::vector<std::pair<std::string, std::string>> kv;

  /// How errors name the switch ("--effect cable") and one of its keys ("--effect cable k").
  std::string where() const { return "--effect " + name; }
  std::string what(const std::string& key) const { return where() + " " + key; }
  ConfigError unknownKey(const std::string& key) const {
    return ConfigError(where() + ": unknown key '" + key + "' (see ftid simulate --help)");
  }
};

void parseCable(const EffectArgs& a, CellSimConfig& c) {
  c.cable.enabled = true;
  for (const auto& [k, v] : a.kv) {
    if (k == "k") c.cable.stiffness_N_per_m = number(v, a.what(k));
    else if (k == "anchor") c.cable.p_BA_B = vector3(v, a.what(k));
    else if (k == "attach") c.cable.p_SA_S = vector3(v, a.what(k));
    else throw a.unknownKey(k);
  }
}

void parseTemperatureDrift(const EffectArgs& a, CellSimConfig& c) {
  c.temperature_drift.enabled = true;
  for (const auto& [k, v] : a.kv) {
    if (k == "df") c.temperature_drift.dF0_dT_N_per_degC = vector3(v, a.what(k));
    else if (k == "dt") c.temperature_drift.dT0_dT_Nm_per_degC = vector3(v, a.what(k));
    else if (k == "ref") c.temperature_drift.reference_degC = number(v, a.what(k));
    else throw a.unknownKey(k);
  }
}

void parseTimeDrift(const EffectArgs& a, CellSimConfig& c) {
  c.time_drift.enabled = true;
  for (const auto& [k, v] : a.kv) {
    if (k == "df") c.time_drift.dF0_dt_N_per_s = vector3(v, a.what(k));
    else if (k == "dt") c.time_drift.dT0_dt_Nm_per_s = vector3(v, a.what(k));
    else throw a.unknownKey(k);
  }
}

void parseSensorDelay(const EffectArgs& a, CellSimConfig& c) {
  c.sensor_delay.enabled = true;
  for (const auto& [k, v] : a.kv) {
    if (k == "tau") c.sensor_delay.tau_s = number(v, a.what(k));
    else throw a.unknownKey(k);
  }
}

void parseCrosstalk(const EffectArgs& a, CellSimConfig& c) {
  c.crosstalk.enabled = true;
  for (const auto& [k, v] : a.kv) {
    if (k == "scale") c.crosstalk.E *= number(v, a.what(k));
    else throw a.unknownKey(k);
  }
}

void parseContact(const EffectArgs& a, CellSimConfig& c) {
  c.contact.enabled = true;
  for (const auto& [k, v] : a.kv) {
    if (k == "start") c.contact.t_start_s = number(v, a.what(k));
    else if (k == "end") c.contact.t_end_s = number(v, a.what(k));
    else if (k == "force") c.contact.force_B = vector3(v, a.what(k));
    else if (k == "point") c.contact.p_SP_S = vector3(v, a.what(k));
    else throw a.unknownKey(k);
  }
}

void parseGlitches(const EffectArgs& a, CellSimConfig& c) {
  c.glitches.enabled = true;
  for (const auto& [k, v] : a.kv) {
    if (k == "p") c.glitches.probability = number(v, a.what(k));
    else if (k == "force") c.glitches.force_N = number(v, a.what(k));
    else if (k == "torque") c.glitches.torque_Nm = number(v, a.what(k));
    else throw a.unknownKey(k);
  }
}

/// Saturation (issue 22): `saturation:fz=118.3,tx=10`, the sensor's range per axis [N, Nm].
void parseSaturation(const EffectArgs& a, CellSimConfig& c) {
  if (a.kv.empty()) throw ConfigError(a.where() + ": name at least one axis, e.g. saturation:fz=120");
  for (const auto& [k, v] : a.kv) {
    int axis = -1;
    for (int i = 0; i < 6; ++i) axis = k == kWrenchAxisNames[i] ? i : axis;
    if (axis < 0) throw a.unknownKey(k);
    const double limit = number(v, a.what(k));
    if (!(limit > 0.0)) throw ConfigError(a.what(k) + ": the range must be positive");
    c.saturation.limit(axis) = limit;
  }
}

/// A compliant mount (issue 22): `mount_dynamics:f=3,zeta=0.1`.
void parseMountDynamics(const EffectArgs& a, CellSimConfig& c) {
  c.mount_dynamics.enabled = true;
  for (const auto& [k, v] : a.kv) {
    if (k == "f") c.mount_dynamics.f_n_hz = number(v, a.what(k));
    else if (k == "zeta") c.mount_dynamics.zeta = number(v, a.what(k));
    else throw a.unknownKey(k);
  }
}

void parseMounting(const EffectArgs& a, CellSimConfig& c) {
  c.mounting.enabled = true;
  constexpr double kDeg = 3.141592653589793 / 180.0;
  Vec3 rpy_deg(0.0, 0.0, 3.0);
  for (const auto& [k, v] : a.kv) {
    if (k == "roll") rpy_deg.x() = number(v, a.what(k));
    else if (k == "pitch") rpy_deg.y() = number(v, a.what(k));
    else if (k == "yaw") rpy_deg.z() = number(v, a.what(k));
    else throw a.unknownKey(k);
  }
  c.mounting.rpy_rad = rpy_deg * kDeg;
}

void parseImu(const EffectArgs& a, CellSimConfig& c) {
  c.imu.enabled = true;
  for (const auto& [k, v] : a.kv) {
    if (k == "acc_bias") c.imu.acc_bias_mps2 = vector3(v, a.what(k));
    else if (k == "gyro_bias") c.imu.gyro_bias_radps = vector3(v, a.what(k));
    else if (k == "delay") c.imu.delay_s = number(v, a.what(k));
    else throw a.unknownKey(k);
  }
}

void parseRigidBody(const EffectArgs& a, CellSimConfig& c) {
  if (!a.kv.empty()) throw a.unknownKey(a.kv.front().first);
  c.full_rigid_body = true;
}

/// An object grasped at t (`release`: held from the start, let go at t): a compact cube of `mass`
/// and `side` at `com`.
void parsePayloadChange(const EffectArgs& a, CellSimConfig& c, bool released) {
  c.payload_change.enabled = true;
  c.payload_change.released = released;
  double mass = 0.6, side = 0.06;
  Vec3 com(0.0, 0.0, 0.12);
  for (const auto& [k, v] : a.kv) {
    if (k == "t") c.payload_change.t_s = number(v, a.what(k));
    else if (k == "mass") mass = number(v, a.what(k));
    else if (k == "com") com = vector3(v, a.what(k));
    else if (k == "side") side = number(v, a.what(k));
    else throw a.unknownKey(k);
  }
  if (!(mass >= 0.0) || !(side >= 0.0)) throw ConfigError(a.where() + ": mass and side must be >= 0");
  c.payload_change.added = compactObject(mass, com, side);
}

void parseGrasp(const EffectArgs& a, CellSimConfig& c) { parsePayloadChange(a, c, false); }
void parseRelease(const EffectArgs& a, CellSimConfig& c) { parsePayloadChange(a, c, true); }

/// Random pushes on the payload (scenarios.hpp), appended to any already scheduled.
void parsePushes(const EffectArgs& a, CellSimConfig& c) {
  PushScenario sc;
  double seed = 1.0, until = 600.0;
  for (const auto& [k, v] : a.kv) {
    if (k == "seed") seed = number(v, a.what(k));
    else if (k == "force") sc.force_N = number(v, a.what(k));
    else if (k == "min") sc.min_duration_s = number(v, a.what(k));
    else if (k == "max") sc.max_duration_s = number(v, a.what(k));
    else if (k == "gap_min") sc.min_gap_s = number(v, a.what(k));
    else if (k == "gap_max") sc.max_gap_s = number(v, a.what(k));
    else if (k == "until") until = number(v, a.what(k));
    else throw a.unknownKey(k);
  }
  const std::string w = a.where();
  if (!(seed >= 0.0 && seed == std::floor(seed) && seed < 1e15)) throw ConfigError(w + " seed: a whole number >= 0");
  if (!(sc.min_duration_s > 0.0 && sc.max_duration_s >= sc.min_duration_s && sc.min_gap_s > 0.0 &&
        sc.max_gap_s >= sc.min_gap_s && until > 0.0 && until <= 86400.0)) {
    throw ConfigError(w + ": needs 0 < min <= max, 0 < gap_min <= gap_max and 0 < until <= 86400");
  }
  const auto more = randomPushes(static_cast<std::uint64_t>(seed), 0.0, until, sc);
  c.pushes.insert(c.pushes.end(), more.begin(), more.end());
}

/// The effect families by name, in the order the error for an unknown name lists them.
struct EffectFamily {
  const char* name;
  void (*parse)(const EffectArgs&, CellSimConfig&);
};
constexpr std::array<EffectFamily, 15> kFamilies{{
    {"cable", parseCable},
    {"temperature_drift", parseTemperatureDrift},
    {"time_drift", parseTimeDrift},
    {"sensor_delay", parseSensorDelay},
    {"crosstalk", parseCrosstalk},
    {"contact", parseContact},
    {"glitches", parseGlitches},
    {"mounting", parseMounting},
    {"imu", parseImu},
    {"rigid_body", parseRigidBody},
    {"grasp", parseGrasp},
    {"release", parseRelease},
    {"pushes", parsePushes},
    {"saturation", parseSaturation},  // saturation (issue 22)
    {"mount_dynamics", parseMountDynamics},  // a compliant mount (issue 22)
}};

/// `NAME[:key=value,...]` split into the name and its key=value pairs.
EffectArgs splitSpec(const std::string& spec) {
  const auto colon = spec.find(':');
  EffectArgs a;
  a.name = spec.substr(0, colon);
  if (colon != std::string::npos) {
    std::stringstream ss(spec.substr(colon + 1));
    std::string item;
    while (std::getline(ss, item, ',')) {
      const auto eq = item.find('=');
      if (eq == std::string::npos) throw ConfigError(a.where() + ": expected key=value, got '" + item + "'");
      a.kv.emplace_back(item.substr(0, eq), item.substr(eq + 1));
    }
  }
  return a;
}

}  // namespace

void applyEffectSpec(const std::string& spec, CellSimConfig& c) {
  const EffectArgs a = splitSpec(spec);
  std::string names;
  for (const EffectFamily& family : kFamilies) {
    if (a.name == family.name) return family.parse(a, c);
    names += (names.empty() ? "" : ", ") + std::string(family.name);
  }
  throw ConfigError("unknown effect '" + a.name + "' (" + names + ")");
}

}  // namespace ftid::sim
