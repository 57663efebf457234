// The effect registry: an explicit built-in table (static registrars in a static library would be
// dropped by the linker) plus effects registered at run time with registerEffect().
//
// To add a named effect in C++: write one class with a factory
//   std::unique_ptr<Effect> makeMyEffect(const std::string& args);
// in a new src/effects/<name>.cpp, and add ONE line to FTID_BUILTIN_EFFECTS below.
#include <algorithm>
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "ftid/common/error.hpp"
#include "ftid/effects/model.hpp"

// X(base_name, factory_function, one-line summary)
#define FTID_BUILTIN_EFFECTS(X)                                                                   \
  X("offsets", makeOffsetsEffect, "constant zero offsets F0, T0 of the sensor")                   \
  X("gravity", makeGravityEffect, "payload weight m g_S at the centre of mass")                   \
  X("tilt", makeTiltEffect, "robot base mounted off level (angles U, V)")                         \
  X("linear_inertia", makeLinearInertiaEffect, "inertial force -m a_S of the payload (paper)")   \
  X("rigid_body", makeRigidBodyEffect, "full Newton-Euler: m(alpha x c + w x (w x c)), I alpha + w x I w") \
  X("cable", makeCableEffect, "cable/hose pulling the tool toward a fixed anchor (linear spring)")  \
  X("temperature_drift", makeTemperatureDriftEffect, "offsets linear in the sensor temperature")    \
  X("time_drift", makeTimeDriftEffect, "offsets drifting linearly with time")                        \
  X("sensor_delay", makeSensorDelayEffect, "wrench lags the kinematics by tau (exact time shift)")    \
  X("mounting", makeMountingEffect, "sensor mounted rotated against X_FS (roll, pitch, yaw)")       \
  X("crosstalk", makeCrosstalkEffect, "gain and cross-axis errors: reading = (I + E) wrench")       \
  X("harmonic", makeHarmonicEffect, "harmonic(s,n): Fourier series in signal s on every axis")       \
  X("poly", makePolyEffect, "poly(s,n[,ref]): polynomial in signal s on every axis")                \
  X("payload", makePayloadSignalEffect, "payload(s[,n[,ref]]): payload mass and centre of mass moving with signal s") \
  X("expr", makeExprEffect, "expr(axes: expression): your own regressor, e.g. expr(fz: grip*qd6)")

namespace ftid::effects {

#define FTID_DECLARE_FACTORY(base, factory, summary) std::unique_ptr<Effect> factory(const std::string& args);
FTID_BUILTIN_EFFECTS(FTID_DECLARE_FACTORY)
#undef FTID_DECLARE_FACTORY

namespace {

struct Entry {
  std::string summary;
  EffectFactory factory;
};

struct Registry {
  std::mutex mutex;
  std::vector<std::string> order;  ///< registration order, for listings
  std::map<std::string, Entry> entries;

  Registry() {
#define FTID_REGISTER_BUILTIN(base, factory, summary) add(base, summary, &factory);
    FTID_BUILTIN_EFFECTS(FTID_REGISTER_BUILTIN)
#undef FTID_REGISTER_BUILTIN
  }
  bool add(const std::string& base, const std::string& summary, EffectFactory factory) {
    if (entries.count(base) != 0) return false;
    entries.emplace(base, Entry{summary, std::move(factory)});
    order.push_back(base);
    return true;
  }
};

Registry& registry() {
  static Registry r;
  return r;
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t");
  return s.substr(b, e - b + 1);
}

}  // namespace

bool registerEffect(const std::string& base_name, const std::string& summary, EffectFactory factory) {
  if (base_name.empty() || !factory) throw ConfigError("registerEffect: empty name or factory");
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  return r.add(base_name, summary, std::move(factory));
}

std::vector<RegisteredEffect> registeredEffects() {
  Registry& r = registry();
  std::lock_guard<std::mutex> lock(r.mutex);
  std::vector<RegisteredEffect> out;
  for (const auto& name : r.order) out.push_back({name, r.entries.at(name).summary});
  return out;
}

std::unique_ptr<Effect> createEffect(const std::string& spec_in) {
  const std::string spec = trim(spec_in);
  std::string base = spec;
  std::string args;
  const auto open = spec.find('(');
  if (open != std::string::npos) {
    if (spec.back() != ')') {
      throw ConfigError("effect '" + spec + "': arguments must be written as name(arg,...)");
    }
    base = trim(spec.substr(0, open));
    args = trim(spec.substr(open + 1, spec.size() - open - 2));
  }
  EffectFactory factory;
  {
    Registry& r = registry();
    std::lock_guard<std::mutex> lock(r.mutex);
    const auto it = r.entries.find(base);
    if (it == r.entries.end()) {
      std::string known;
      for (const auto& name : r.order) known += (known.empty() ? "" : ", ") + name;
      throw ConfigError("unknown effect '" + base + "' (known effects: paper, " + known + ")");
    }
    factory = it->second.factory;
  }
  auto effect = factory(args);
  if (!effect) throw ConfigError("effect '" + spec + "': factory returned nothing");
  return effect;
}

}  // namespace ftid::effects
