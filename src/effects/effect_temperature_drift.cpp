// The `temperature_drift` effect: sensor offsets linear in the sensor temperature,
//   f += dF0/dT (temp - T_ref),   t += dT0/dT (temp - T_ref)
// `temperature_drift` uses T_ref = 25 degC; `temperature_drift(T_ref)` sets it. F0 and T0 of the
// offsets effect are then the offsets at T_ref.
#include <memory>
#include <string>
#include <vector>

#include "effect_args.hpp"
#include "ftid/effects/effect.hpp"

namespace ftid::effects {

namespace {

using RegressorRef = Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>>;

class TemperatureDriftEffect final : public Effect {
 public:
  explicit TemperatureDriftEffect(double reference_degC) : reference_degC_(reference_degC) {}
  std::string name() const override {
    return reference_degC_ == 25.0 ? "temperature_drift"
                                   : "temperature_drift(" + detail::numberText(reference_degC_) + ")";
  }
  std::string description() const override {
    return "sensor zero offsets that change linearly with the sensor temperature";
  }
  std::vector<ParamInfo> params() const override {
    return {{"f0_dtemp_x", "N/degC", "force offset change per degC, x_S"},
            {"f0_dtemp_y", "N/degC", "force offset change per degC, y_S"},
            {"f0_dtemp_z", "N/degC", "force offset change per degC, z_S"},
            {"t0_dtemp_x", "Nm/degC", "moment offset change per degC, x_S"},
            {"t0_dtemp_y", "Nm/degC", "moment offset change per degC, y_S"},
            {"t0_dtemp_z", "Nm/degC", "moment offset change per degC, z_S"}};
  }
  std::vector<std::string> requires() const override { return {"offsets"}; }
  std::uint32_t signals() const override { return kSignalTemperature; }
  void bind(const ParamIndex& index) override {
    const auto p = params();
    for (int i = 0; i < 6; ++i) col_[i] = requireColumn(index, p[static_cast<std::size_t>(i)].name, name());
  }
  void addRegressor(const SampleContext& ctx, RegressorRef Y) const noexcept override {
    const double d = ctx.temp_degC - reference_degC_;
    for (int i = 0; i < 6; ++i) Y(i, col_[i]) += d;
  }
  std::unique_ptr<Effect> clone() const override {
    return std::make_unique<TemperatureDriftEffect>(*this);
  }

 private:
  double reference_degC_;
  int col_[6] = {0, 0, 0, 0, 0, 0};
};

}  // namespace

std::unique_ptr<Effect> makeTemperatureDriftEffect(const std::string& args) {
  const auto a = detail::splitArgs(args);
  if (a.size() > 1) throw ConfigError("effect 'temperature_drift' takes at most one argument (T_ref in degC)");
  const double ref = a.empty() ? 25.0 : detail::parseNumber("temperature_drift", a[0]);
  return std::make_unique<TemperatureDriftEffect>(ref);
}

}  // namespace ftid::effects
