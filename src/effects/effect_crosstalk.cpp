// The `crosstalk` effect: small gain and cross-axis errors of the sensor calibration,
//   reading = (I + E) w + offsets   ~   w_model + E w_model        (first order in E)
// with w_model the current modelled wrench (SampleContext::wrench_model_S, filled by
// effects::ModelEvaluator and the fitter; using the measured wrench instead would regress a reading on its own
// noise). E(r, c) is the part of axis c that leaks into the reading of axis r.
// Directions of E that the payload parameters already express are left out (they would make the
// fit rank deficient): a common force gain (= the mass), a common moment gain (= the first moment
// m c), and the antisymmetric part of the force-to-moment block (= a shift of m c). So the force
// gains are relative to fz, the moment gains relative to tz, and E(t, f) is symmetric:
// 36 - 1 - 1 - 3 = 31 parameters named xt_<row>_<col> (e.g. xt_fx_fy = E(fx, fy)).
#include <memory>
#include <string>
#include <vector>

#include "ftid/common/error.hpp"
#include "ftid/effects/effect.hpp"

namespace ftid::effects {

namespace {

using RegressorRef = Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>>;

struct XtParam {
  int row;
  int col;
  int row2;  ///< second entry sharing the parameter (symmetric E(t,f)), or -1
  int col2;
};

std::vector<XtParam> crosstalkLayout() {
  std::vector<XtParam> out;
  for (int r = 0; r < 6; ++r) {
    for (int c = 0; c < 6; ++c) {
      if (r == 2 && c == 2) continue;  // fz gain: common force gain = mass
      if (r == 5 && c == 5) continue;  // tz gain: common moment gain = m c
      if (r >= 3 && c < 3) {           // moment rows, force columns: symmetric part only
        const int i = r - 3;
        if (c < i) continue;           // counted with its mirror
        out.push_back({r, c, c == i ? -1 : c + 3, c == i ? -1 : i});
        continue;
      }
      out.push_back({r, c, -1, -1});
    }
  }
  return out;
}

class CrosstalkEffect final : public Effect {
 public:
  CrosstalkEffect() : layout_(crosstalkLayout()) {}
  std::string name() const override { return "crosstalk"; }
  std::string description() const override {
    return "gain and cross-axis errors of the sensor calibration: reading = (I + E) wrench";
  }
  std::vector<ParamInfo> params() const override {
    std::vector<ParamInfo> p;
    for (const auto& x : layout_) {
      std::string n = std::string("xt_") + kWrenchAxisNames[x.row] + "_" + kWrenchAxisNames[x.col];
      std::string d = std::string("part of ") + kWrenchAxisNames[x.col] + " read on " + kWrenchAxisNames[x.row];
      if (x.row2 >= 0) d += std::string(" (and of ") + kWrenchAxisNames[x.col2] + " on " + kWrenchAxisNames[x.row2] + ")";
      const bool same_unit = (x.row < 3) == (x.col < 3);
      p.push_back({n, same_unit ? "1" : (x.row < 3 ? "1/m" : "m"), d});
    }
    return p;
  }
  std::uint32_t signals() const override { return kSignalModelWrench; }
  void bind(const ParamIndex& index) override {
    const auto p = params();
    cols_.clear();
    for (const auto& info : p) cols_.push_back(requireColumn(index, info.name, name()));
  }
  void addRegressor(const SampleContext& ctx, RegressorRef Y) const noexcept override {
    for (std::size_t k = 0; k < layout_.size(); ++k) {
      const auto& x = layout_[k];
      Y(x.row, cols_[k]) += ctx.wrench_model_S(x.col);
      if (x.row2 >= 0) Y(x.row2, cols_[k]) += ctx.wrench_model_S(x.col2);
    }
  }
  std::unique_ptr<Effect> clone() const override { return std::make_unique<CrosstalkEffect>(*this); }

 private:
  std::vector<XtParam> layout_;
  std::vector<int> cols_;
};

}  // namespace

std::unique_ptr<Effect> makeCrosstalkEffect(const std::string& args) {
  if (!args.empty()) throw ConfigError("effect 'crosstalk' takes no arguments (got '" + args + "')");
  return std::make_unique<CrosstalkEffect>();
}

}  // namespace ftid::effects
