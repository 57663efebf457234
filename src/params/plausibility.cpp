// Plausibility of a parameter set against what the robot and the sensor can carry (issue 26).
#include <cmath>
#include <cstdio>
#include <string>

#include "ftid/params/parameter_set.hpp"

namespace ftid::params {
namespace {

std::string fmt(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

double valueOr(const ParameterSet& set, const char* name, double fallback) {
  for (const auto& p : set.params) {
    if (p.name == name) return p.value;
  }
  return fallback;
}

constexpr const char* kAxisKeys[6] = {"f0_x", "f0_y", "f0_z", "t0_x", "t0_y", "t0_z"};

}  // namespace

std::optional<ParameterProblem> findParameterProblem(const ParameterSet& set, const PlausibilityLimits& limits) {
  if (auto problem = findParameterProblem(set)) return problem;
  const double mass = valueOr(set, "mass", 0.0);
  if (mass > limits.max_payload_kg) {
    return ParameterProblem{"parameters.mass", "mass " + fmt(mass) + " kg exceeds the robot's rated payload " +
                                                   fmt(limits.max_payload_kg) + " kg (" + limits.payload_source +
                                                   "): not a payload this robot can carry"};
  }
  const double g = limits.gravity_mps2;
  const Vec3 mc(valueOr(set, "mass_com_x", 0.0), valueOr(set, "mass_com_y", 0.0), valueOr(set, "mass_com_z", 0.0));
  for (int a = 0; a < 6; ++a) {
    const double offset = std::abs(valueOr(set, kAxisKeys[a], 0.0));
    double load = 0.0;
    if (a < 3) {
      load = mass * g;
    } else {
      const int k = a - 3;
      load = g * std::hypot(mc((k + 1) % 3), mc((k + 2) % 3));
    }
    const double worst = offset + load;
    if (worst > limits.sensor_range(a)) {
      static constexpr const char* kAxes[6] = {"Fx", "Fy", "Fz", "Tx", "Ty", "Tz"};
      const char* unit = a < 3 ? " N" : " Nm";
      return ParameterProblem{
          a < 3 ? std::string("parameters.mass") : std::string("parameters.mass_com_") + "xyz"[(a - 3 + 1) % 3],
          std::string("the model's static wrench reaches |") + kAxes[a] + "| = " + fmt(worst) + unit +
              " (offset " + fmt(offset) + " + gravity load " + fmt(load) + ") in the worst orientation, beyond the "
              "sensor's rated range " + fmt(limits.sensor_range(a)) + unit + " (" + limits.range_source + ")"};
    }
  }
  return std::nullopt;
}

}  // namespace ftid::params
