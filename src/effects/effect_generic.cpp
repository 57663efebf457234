// Generic effects, usable from the command line without C++ (docs/effects.md):
//   harmonic(s,n)       sum_{k=1..n} a_k sin(k s) + b_k cos(k s) on each of the 6 axes (12 n params)
//   poly(s,n[,s_ref])   sum_{p=1..n} c_p (s - s_ref)^p on each of the 6 axes        (6 n params)
// s is any signal of ftid/effects/signal_source.hpp (t, temp, q1..q6, wz, ..., an extra log
// column). s_ref defaults to 25 for temp and 0 otherwise; the constant term is the offsets'.
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "effect_args.hpp"
#include "ftid/effects/effect.hpp"
#include "ftid/effects/signal_source.hpp"

namespace ftid::effects {

namespace {

using RegressorRef = Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>>;
constexpr int kMaxHarmonicOrder = 8;
constexpr int kMaxPolyOrder = 5;

class HarmonicEffect final : public Effect {
 public:
  HarmonicEffect(SignalSource source, int order) : source_(std::move(source)), order_(order) {}
  std::string name() const override {
    return "harmonic(" + source_.name() + "," + std::to_string(order_) + ")";
  }
  std::string description() const override {
    return "a periodic disturbance in " + source_.name() + " (Fourier series up to order " +
           std::to_string(order_) + " on every axis), e.g. cable routing or a joint-angle-dependent load";
  }
  std::vector<ParamInfo> params() const override {
    std::vector<ParamInfo> p;
    for (int k = 1; k <= order_; ++k) {
      for (const char* sc : {"s", "c"}) {
        for (int a = 0; a < 6; ++a) {
          p.push_back({"harm_" + source_.name() + "_" + std::to_string(k) + sc + "_" + kWrenchAxisNames[a],
                       a < 3 ? "N" : "Nm",
                       std::string(sc[0] == 's' ? "sin" : "cos") + "(" + std::to_string(k) + " " +
                           source_.name() + ") coefficient on " + kWrenchAxisNames[a]});
        }
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
    const double s = source_.read(ctx);
    std::size_t c = 0;
    for (int k = 1; k <= order_; ++k) {
      const double sv = std::sin(k * s);
      const double cv = std::cos(k * s);
      for (int a = 0; a < 6; ++a) Y(a, cols_[c++]) += sv;
      for (int a = 0; a < 6; ++a) Y(a, cols_[c++]) += cv;
    }
  }
  std::unique_ptr<Effect> clone() const override { return std::make_unique<HarmonicEffect>(*this); }

 private:
  SignalSource source_;
  int order_;
  std::vector<int> cols_;
};

class PolyEffect final : public Effect {
 public:
  PolyEffect(SignalSource source, int order, double reference, bool explicit_reference)
      : source_(std::move(source)), order_(order), reference_(reference), explicit_ref_(explicit_reference) {}
  std::string name() const override {
    std::string n = "poly(" + source_.name() + "," + std::to_string(order_);
    if (explicit_ref_) n += "," + detail::numberText(reference_);
    return n + ")";
  }
  std::string description() const override {
    return "a smooth dependence of the reading on " + source_.name() + " (polynomial of order " +
           std::to_string(order_) + " on every axis)";
  }
  std::vector<ParamInfo> params() const override {
    std::vector<ParamInfo> p;
    const std::string unit_s = source_.unit();
    for (int k = 1; k <= order_; ++k) {
      for (int a = 0; a < 6; ++a) {
        std::string unit = std::string(a < 3 ? "N" : "Nm") + "/" + unit_s;
        if (k > 1) unit += "^" + std::to_string(k);
        p.push_back({"poly_" + source_.name() + "_" + std::to_string(k) + "_" + kWrenchAxisNames[a], unit,
                     "coefficient of (" + source_.name() + " - " + detail::numberText(reference_) + ")^" +
                         std::to_string(k) + " on " + kWrenchAxisNames[a]});
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
    double pw = 1.0;
    std::size_t c = 0;
    for (int k = 1; k <= order_; ++k) {
      pw *= d;
      for (int a = 0; a < 6; ++a) Y(a, cols_[c++]) += pw;
    }
  }
  std::unique_ptr<Effect> clone() const override { return std::make_unique<PolyEffect>(*this); }

 private:
  SignalSource source_;
  int order_;
  double reference_;
  bool explicit_ref_;
  std::vector<int> cols_;
};

}  // namespace

std::unique_ptr<Effect> makeHarmonicEffect(const std::string& args) {
  const auto a = detail::splitArgs(args);
  if (a.size() != 2) {
    throw ConfigError("effect 'harmonic' needs two arguments: harmonic(signal,order), e.g. harmonic(q4,2)");
  }
  return std::make_unique<HarmonicEffect>(SignalSource::parse(a[0]),
                                          detail::parseOrder("harmonic", a[1], kMaxHarmonicOrder));
}

std::unique_ptr<Effect> makePolyEffect(const std::string& args) {
  const auto a = detail::splitArgs(args);
  if (a.size() < 2 || a.size() > 3) {
    throw ConfigError("effect 'poly' needs poly(signal,order[,reference]), e.g. poly(temp,2) or poly(t,3)");
  }
  auto source = SignalSource::parse(a[0]);
  const int order = detail::parseOrder("poly", a[1], kMaxPolyOrder);
  const bool explicit_ref = a.size() == 3;
  const double ref = explicit_ref ? detail::parseNumber("poly", a[2]) : (a[0] == "temp" ? 25.0 : 0.0);
  return std::make_unique<PolyEffect>(std::move(source), order, ref, explicit_ref);
}

}  // namespace ftid::effects
