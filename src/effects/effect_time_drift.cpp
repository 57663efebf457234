// The `time_drift` effect: sensor offsets drifting linearly with the model's time t_model
// (seconds since the parameter set's time origin; docs/conventions.md, "Time and logs"),
//   f += dF0/dt t_model,   t += dT0/dt t_model
#include <memory>
#include <string>
#include <vector>

#include "ftid/common/error.hpp"
#include "ftid/effects/effect.hpp"

namespace ftid::effects {

namespace {

using RegressorRef = Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>>;

class TimeDriftEffect final : public Effect {
 public:
  std::string name() const override { return "time_drift"; }
  std::string description() const override {
    return "sensor zero offsets drifting linearly with time (e.g. charge leakage, creep)";
  }
  std::vector<ParamInfo> params() const override {
    return {{"f0_dt_x", "N/s", "force offset drift rate, x_S"},
            {"f0_dt_y", "N/s", "force offset drift rate, y_S"},
            {"f0_dt_z", "N/s", "force offset drift rate, z_S"},
            {"t0_dt_x", "Nm/s", "moment offset drift rate, x_S"},
            {"t0_dt_y", "Nm/s", "moment offset drift rate, y_S"},
            {"t0_dt_z", "Nm/s", "moment offset drift rate, z_S"}};
  }
  std::vector<std::string> requires() const override { return {"offsets"}; }
  std::uint32_t signals() const override { return kSignalTime; }
  void bind(const ParamIndex& index) override {
    const auto p = params();
    for (int i = 0; i < 6; ++i) col_[i] = requireColumn(index, p[static_cast<std::size_t>(i)].name, name());
  }
  void addRegressor(const SampleContext& ctx, RegressorRef Y) const noexcept override {
    for (int i = 0; i < 6; ++i) Y(i, col_[i]) += ctx.t_model;
  }
  std::unique_ptr<Effect> clone() const override { return std::make_unique<TimeDriftEffect>(*this); }

 private:
  int col_[6] = {0, 0, 0, 0, 0, 0};
};

}  // namespace

std::unique_ptr<Effect> makeTimeDriftEffect(const std::string& args) {
  if (!args.empty()) throw ConfigError("effect 'time_drift' takes no arguments (got '" + args + "')");
  return std::make_unique<TimeDriftEffect>();
}

}  // namespace ftid::effects
