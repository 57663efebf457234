#pragma once
// A scalar signal read from a SampleContext by name, for generic effects (poly, harmonic) and for
// the residual diagnostics of `ftid analyze`. Names (units SI, docs/conventions.md):
//   t                    time since the first sample [s]
//   temp                 sensor temperature [degC]
//   q1..q6, qd1..qd6     joint angles [rad] and velocities [rad/s]
//   wx wy wz             angular velocity w_S [rad/s]
//   alx aly alz          angular acceleration alpha_S [rad/s^2]
//   ax ay az             linear acceleration a_S of the S origin (kinematics, no gravity) [m/s^2]
//   gx gy gz             gravity direction g_S [m/s^2]
//   <other>              an extra log column of that name (SampleContext::extra_names)
#include <cstdint>
#include <string>
#include <vector>

#include "ftid/effects/effect.hpp"
#include "ftid/effects/model.hpp"

namespace ftid::effects {

class SignalSource {
 public:
  /// Parses a signal name; throws ConfigError for an empty name. Unknown names are taken as extra
  /// log columns (checked against the log by available()).
  static SignalSource parse(const std::string& name);

  /// The value for one sample; NaN if the signal is an extra column the sample does not have.
  /// Real-time safe (no allocation).
  double read(const SampleContext& ctx) const noexcept;
  /// True if the sample carries this signal (temp needs has_temp, extra columns need the name).
  bool available(const SampleContext& ctx) const noexcept;

  const std::string& name() const { return name_; }
  std::string unit() const;
  /// Signal bits (effects::Signal) this source reads.
  std::uint32_t signals() const;
  bool isAngle() const { return kind_ == Kind::kJointAngle; }

 private:
  enum class Kind { kTime, kTemp, kJointAngle, kJointVelocity, kAngVel, kAngAcc, kLinAcc, kGravity, kExtra };
  Kind kind_ = Kind::kTime;
  int index_ = 0;
  std::string name_;
};

/// The extra log columns a model reads (the signals of its effects that read kSignalExtraColumn,
/// e.g. "grip" for payload(grip) or poly(grip,1)), each once, in effect order. Compensation needs
/// them at run time: `ftid compensate` from the log's columns; ftidd has none (docs/effects.md).
std::vector<std::string> extraColumnsRead(const Model& model);

}  // namespace ftid::effects
