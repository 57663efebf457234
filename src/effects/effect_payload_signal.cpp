// payload(s[,n[,s_ref]]): payload parameters that move with a signal (docs/effects.md).
//
// A part of the payload whose mass m(s) and first moment (m c)(s) change with a logged signal s: a
// gripper jaw moving with `grip`, a dispensing tool losing mass with `t`. With d = s - s_ref,
//   m(s)     = m(s_ref)     + sum_{k=1..n} dmass_k d^k
//   (mc)(s)  = (mc)(s_ref)  + sum_{k=1..n} dmass_com_k d^k
// and the payload's force and moment (docs/conventions.md; as gravity + linear_inertia + the force
// part of rigid_body) applied to the changing part:
//   f += d^k [ dm (g_S - a_S) - alpha_S x dmc - w_S x (w_S x dmc) ]
//   t += d^k [ dmc x (g_S - a_S) ]
// The constant part (s = s_ref) is the model's own mass and mass_com. Not modelled: the moving
// part's inertia (second order in its distance from S) and its motion relative to S (the signal
// is taken as slow). The gravity slope reads s, so constantGravitySlope() is false.
#include <memory>
#include <string>
#include <vector>

#include "effect_args.hpp"
#include "ftid/effects/effect.hpp"
#include "ftid/effects/signal_source.hpp"

namespace ftid::effects {

namespace {

using RegressorRef = Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>>;
constexpr int kMaxPayloadOrder = 3;

class PayloadSignalEffect final : public Effect {
 public:
  PayloadSignalEffect(SignalSource source, int order, double reference)
      : source_(std::move(source)), order_(order), reference_(reference) {}

  std::string name() const override {
    std::string n = "payload(" + source_.name();  // canonical: payload(grip,1,0) is payload(grip)
    if (order_ > 1 || reference_ != 0.0) n += "," + std::to_string(order_);
    if (reference_ != 0.0) n += "," + detail::numberText(reference_);
    return n + ")";
  }
  std::string description() const override {
    return "payload mass and centre of mass moving with " + source_.name() +
           " (e.g. a gripper jaw or a dispensed mass): its weight and inertial force, polynomial of order " +
           std::to_string(order_);
  }
  std::vector<ParamInfo> params() const override {
    std::vector<ParamInfo> p;
    const std::string unit_s = source_.unit();  // "1" for an extra column: kg per unit of it
    const std::string per = unit_s == "1" ? "" : "/" + unit_s;
    for (int k = 1; k <= order_; ++k) {
      const std::string power = k == 1 || per.empty() ? "" : "^" + std::to_string(k);
      const std::string of = " per (" + source_.name() + " - " + detail::numberText(reference_) + ")" + power;
      p.push_back({massName(k), "kg" + per + power, "change of the payload mass" + of});
      for (const char* axis : {"x", "y", "z"}) {
        p.push_back({comName(k, axis), "kg*m" + per + power,
                     std::string("change of the first moment m c_") + axis + of});
      }
    }
    return p;
  }
  std::uint32_t signals() const override { return source_.signals(); }
  std::vector<std::string> signalNames() const override { return {source_.name()}; }
  void bind(const ParamIndex& index) override {
    cols_.clear();
    for (const auto& info : params()) cols_.push_back(requireColumn(index, info.name, name()));
  }
  void addRegressor(const SampleContext& ctx, RegressorRef Y) const noexcept override {
    const double d = source_.read(ctx) - reference_;
    const Vec3 v = ctx.g_S - ctx.a_S;  // weight and linear inertia per kg
    const Mat3 sw = skew(ctx.w_S);
    const Mat3 force_mc = -(skew(ctx.alpha_S) + sw * sw);  // -alpha x mc - w x (w x mc)
    const Mat3 moment_mc = -skew(v);                        // mc x v
    double pw = 1.0;
    std::size_t c = 0;
    for (int k = 1; k <= order_; ++k) {
      pw *= d;
      const int m = cols_[c++];
      for (int i = 0; i < 3; ++i) Y(i, m) += pw * v(i);
      for (int j = 0; j < 3; ++j) {
        const int col = cols_[c++];
        for (int i = 0; i < 3; ++i) {
          Y(i, col) += pw * force_mc(i, j);
          Y(3 + i, col) += pw * moment_mc(i, j);
        }
      }
    }
  }
  bool changesPayloadMass() const override { return true; }
  double payloadMassChange(const SampleContext& ctx, const Eigen::VectorXd& theta) const override {
    const double d = source_.read(ctx) - reference_;
    double pw = 1.0, change = 0.0;
    for (int k = 1; k <= order_; ++k) {
      pw *= d;
      change += pw * theta(cols_[static_cast<std::size_t>(4 * (k - 1))]);  // dmass_k: the first of each order's four
    }
    return change;
  }
  std::unique_ptr<Effect> clone() const override { return std::make_unique<PayloadSignalEffect>(*this); }

 private:
  std::string suffix(int k) const { return source_.name() + (k == 1 ? "" : "_" + std::to_string(k)); }
  std::string massName(int k) const { return "dmass_" + suffix(k); }
  std::string comName(int k, const char* axis) const { return "dmass_com_" + suffix(k) + "_" + axis; }

  SignalSource source_;
  int order_;
  double reference_;
  std::vector<int> cols_;
};

}  // namespace

std::unique_ptr<Effect> makePayloadSignalEffect(const std::string& args) {
  const auto a = detail::splitArgs(args);
  if (a.empty() || a.size() > 3) {
    throw ConfigError("effect 'payload' needs payload(signal[,order[,reference]]), e.g. payload(grip) or payload(t,2)");
  }
  auto source = SignalSource::parse(a[0]);
  const int order = a.size() >= 2 ? detail::parseOrder("payload", a[1], kMaxPayloadOrder) : 1;
  const double ref = a.size() == 3 ? detail::parseNumber("payload", a[2]) : 0.0;
  return std::make_unique<PayloadSignalEffect>(std::move(source), order, ref);
}

}  // namespace ftid::effects
