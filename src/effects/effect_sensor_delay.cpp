// The `sensor_delay` effect: the wrench stream lags the kinematics/IMU by tau. To first order,
//   w_measured(t) = w_model(t - tau) ~ w_model(t) - tau d/dt w_model(t)
// so the column of the parameter `delay` (tau [s]) is -d/dt of the modelled wrench, which the
// fitter supplies in SampleContext::dwrench_model_dt (kSignalModelDerivative) and iterates.
// Valid while tau times the highest motion frequency is small (second-order error tau^2/2 w'').
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
    return "the wrench stream lags the kinematics/IMU by a delay tau (first order: -tau dw/dt)";
  }
  std::vector<ParamInfo> params() const override {
    return {{"delay", "s", "delay tau of the wrench reading behind the kinematics"}};
  }
  std::uint32_t signals() const override { return kSignalModelDerivative; }
  void bind(const ParamIndex& index) override { col_ = requireColumn(index, "delay", name()); }
  void addRegressor(const SampleContext& ctx, RegressorRef Y) const noexcept override {
    for (int i = 0; i < 6; ++i) Y(i, col_) -= ctx.dwrench_model_dt(i);
  }
  std::unique_ptr<Effect> clone() const override { return std::make_unique<SensorDelayEffect>(*this); }

 private:
  int col_ = 0;
};

}  // namespace

std::unique_ptr<Effect> makeSensorDelayEffect(const std::string& args) {
  if (!args.empty()) throw ConfigError("effect 'sensor_delay' takes no arguments (got '" + args + "')");
  return std::make_unique<SensorDelayEffect>();
}

}  // namespace ftid::effects
