// The user's own effect, written on the command line (docs/effects.md, "Your own effect without C++"):
//
//   expr(AXES: EXPRESSION)      e.g. expr(fz: grip*qd6)   expr(fx/fy: sin(q6)*gz)
//
// One parameter per axis, the coefficient of the expression on that axis:
//   reading_axis += c_axis * EXPRESSION(sample)
// AXES is one of fx fy fz tx ty tz, or several joined by '/'. EXPRESSION is an
// effects::Expression of the sample's signals (include/ftid/effects/expression.hpp).
#include <algorithm>
#include <cctype>
#include <memory>
#include <string>
#include <vector>

#include "ftid/common/error.hpp"
#include "ftid/effects/effect.hpp"
#include "ftid/effects/expression.hpp"

namespace ftid::effects {

namespace {

using RegressorRef = Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>>;

/// The expression as a parameter-name fragment: operators in words, other symbols as '_'
/// (grip*qd6 -> grip_times_qd6; a*b and a+b stay distinct).
std::string nameFragment(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '+': out += "_plus_"; break;
      case '-': out += "_minus_"; break;
      case '*': out += "_times_"; break;
      case '/': out += "_over_"; break;
      case '^': out += "_pow_"; break;
      case '.': out += 'p'; break;
      default:
        out += std::isalnum(static_cast<unsigned char>(c)) ? static_cast<char>(std::tolower(c)) : '_';
    }
  }
  std::string squeezed;
  for (char c : out) {
    if (c == '_' && (squeezed.empty() || squeezed.back() == '_')) continue;
    squeezed += c;
  }
  while (!squeezed.empty() && squeezed.back() == '_') squeezed.pop_back();
  return squeezed;
}

class ExprEffect final : public Effect {
 public:
  ExprEffect(std::vector<int> axes, Expression expression) : axes_(std::move(axes)), expr_(std::move(expression)) {}

  std::string name() const override { return "expr(" + axesText() + ": " + expr_.text() + ")"; }
  std::string description() const override {
    return "your own effect: a coefficient times " + expr_.text() + " on " + axesText();
  }
  std::vector<ParamInfo> params() const override {
    std::vector<ParamInfo> p;
    for (int axis : axes_) {
      const std::string axis_name = kWrenchAxisNames[axis];
      p.push_back({"expr_" + axis_name + "_" + nameFragment(expr_.text()),
                   std::string(axis < 3 ? "N" : "Nm") + " per unit of " + expr_.text(),
                   "coefficient of " + expr_.text() + " on " + axis_name});
    }
    return p;
  }
  std::uint32_t signals() const override { return expr_.signalBits(); }
  std::vector<std::string> signalNames() const override {
    std::vector<std::string> n;
    for (const auto& s : expr_.signals()) n.push_back(s.name());
    return n;
  }
  void bind(const ParamIndex& index) override {
    cols_.clear();
    for (const auto& info : params()) cols_.push_back(requireColumn(index, info.name, name()));
  }
  void addRegressor(const SampleContext& ctx, RegressorRef Y) const noexcept override {
    const double v = expr_.evaluate(ctx);  // NaN where undefined: the fit refuses it (missingSignal)
    for (std::size_t k = 0; k < axes_.size(); ++k) Y(axes_[k], cols_[k]) += v;
  }
  std::unique_ptr<Effect> clone() const override { return std::make_unique<ExprEffect>(*this); }

 private:
  std::string axesText() const {
    std::string a;
    for (int axis : axes_) a += (a.empty() ? "" : "/") + std::string(kWrenchAxisNames[axis]);
    return a;
  }

  std::vector<int> axes_;
  Expression expr_;
  std::vector<int> cols_;
};

std::string trimmed(const std::string& s) {
  const auto b = s.find_first_not_of(" \t");
  const auto e = s.find_last_not_of(" \t");
  return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
}

std::vector<int> parseAxes(const std::string& text) {
  std::vector<int> axes;
  std::size_t start = 0;
  for (;;) {
    const auto slash = text.find('/', start);
    const std::string a = trimmed(text.substr(start, slash == std::string::npos ? std::string::npos : slash - start));
    const auto it = std::find(std::begin(kWrenchAxisNames), std::end(kWrenchAxisNames), a);
    if (it == std::end(kWrenchAxisNames)) {
      throw ConfigError("effect 'expr': '" + a + "' is not an axis (fx fy fz tx ty tz, several joined by '/')");
    }
    const int axis = static_cast<int>(it - std::begin(kWrenchAxisNames));
    if (std::find(axes.begin(), axes.end(), axis) != axes.end()) {
      throw ConfigError("effect 'expr': axis '" + a + "' is named twice");
    }
    axes.push_back(axis);
    if (slash == std::string::npos) return axes;
    start = slash + 1;
  }
}

}  // namespace

std::unique_ptr<Effect> makeExprEffect(const std::string& args) {
  const auto colon = args.find(':');
  if (colon == std::string::npos) {
    throw ConfigError("effect 'expr' is written expr(AXES: EXPRESSION), e.g. expr(fz: grip*qd6) or "
                      "expr(fx/fy: sin(q6)*gz); '" + args + "' has no ':'");
  }
  return std::make_unique<ExprEffect>(parseAxes(args.substr(0, colon)), Expression::parse(args.substr(colon + 1)));
}

}  // namespace ftid::effects
