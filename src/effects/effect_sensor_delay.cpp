// The `sensor_delay` effect: the wrench stream lags (or leads) the kinematics/IMU by tau,
//   w_measured(t) = w_model(kinematics at t - tau)                      (exact, either sign)
// tau is a nonlinear parameter (`delay` [s], effects/nonlinear.hpp): the fitter estimates it by
// shifting the kinematics in time with interpolation (search range configurable, the first-order
// estimate -tau dw/dt only as a start), and the compensator pairs each reading with the
// kinematic state tau earlier from a fixed ring of recent states. No regressor columns.
#include <memory>
#include <string>
#include <vector>

#include "ftid/common/error.hpp"
#include "ftid/effects/effect.hpp"

namespace ftid::effects {

namespace {

using RegressorRef = Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>>;

class SensorDelayEffect final : public Effect {
 public:
  std::string name() const override { return "sensor_delay"; }
  std::string description() const override {
    return "the wrench stream lags the kinematics/IMU by a delay tau (exact time shift, either sign)";
  }
  std::vector<ParamInfo> params() const override { return {}; }
  bool estimatesDelay() const override { return true; }
  void bind(const ParamIndex& /*index*/) override {}
  void addRegressor(const SampleContext& /*ctx*/, RegressorRef /*Y*/) const noexcept override {}
  std::unique_ptr<Effect> clone() const override { return std::make_unique<SensorDelayEffect>(*this); }
};

class MountingEffect final : public Effect {
 public:
  std::string name() const override { return "mounting"; }
  std::string description() const override {
    return "the sensor is mounted rotated against the configured X_FS (roll, pitch, yaw)";
  }
  std::vector<ParamInfo> params() const override { return {}; }
  std::vector<std::string> requires() const override { return {"gravity"}; }
  bool estimatesMounting() const override { return true; }
  void bind(const ParamIndex& /*index*/) override {}
  void addRegressor(const SampleContext& /*ctx*/, RegressorRef /*Y*/) const noexcept override {}
  std::unique_ptr<Effect> clone() const override { return std::make_unique<MountingEffect>(*this); }
};

}  // namespace

std::unique_ptr<Effect> makeSensorDelayEffect(const std::string& args) {
  if (!args.empty()) throw ConfigError("effect 'sensor_delay' takes no arguments (got '" + args + "')");
  return std::make_unique<SensorDelayEffect>();
}

std::unique_ptr<Effect> makeMountingEffect(const std::string& args) {
  if (!args.empty()) throw ConfigError("effect 'mounting' takes no arguments (got '" + args + "')");
  return std::make_unique<MountingEffect>();
}

}  // namespace ftid::effects
