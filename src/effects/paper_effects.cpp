// The four effects of the paper's model (docs/effects.md, docs/conventions.md):
//   offsets         f += F0,           t += T0
//   gravity         f += m g_S,        t += (m c) x g_S
//   tilt            (no linear parameters; the fitter estimates U, V, which set g_S)
//   linear_inertia  f -= m a_S,        t -= (m c) x a_S      (Newton: payload force m (g_S - a_S))
// Each is linear in its parameters; (m c) x v = -skew(v) (m c) gives the moment columns.
#include <memory>
#include <string>
#include <vector>

#include "ftid/common/error.hpp"
#include "ftid/effects/effect.hpp"

namespace ftid::effects {

namespace {

using RegressorRef = Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>>;

void rejectArgs(const std::string& name, const std::string& args) {
  if (!args.empty()) throw ConfigError("effect '" + name + "' takes no arguments (got '" + args + "')");
}

class OffsetsEffect final : public Effect {
 public:
  std::string name() const override { return "offsets"; }
  std::string description() const override {
    return "constant zero offsets F0, T0 of the sensor reading";
  }
  std::vector<ParamInfo> params() const override {
    return {{"f0_x", "N", "force offset along x_S"},   {"f0_y", "N", "force offset along y_S"},
            {"f0_z", "N", "force offset along z_S"},   {"t0_x", "Nm", "moment offset about x_S"},
            {"t0_y", "Nm", "moment offset about y_S"}, {"t0_z", "Nm", "moment offset about z_S"}};
  }
  void bind(const ParamIndex& index) override {
    const char* names[6] = {"f0_x", "f0_y", "f0_z", "t0_x", "t0_y", "t0_z"};
    for (int i = 0; i < 6; ++i) col_[i] = requireColumn(index, names[i], name());
  }
  void addRegressor(const SampleContext& /*ctx*/, RegressorRef Y) const noexcept override {
    for (int i = 0; i < 6; ++i) Y(i, col_[i]) += 1.0;
  }
  std::unique_ptr<Effect> clone() const override { return std::make_unique<OffsetsEffect>(*this); }

 private:
  int col_[6] = {0, 0, 0, 0, 0, 0};
};

/// Columns of `mass` and `mass_com_x/y/z` resolved once; shared by gravity and linear_inertia.
struct MassColumns {
  int mass = 0;
  int mc_xyz[3] = {0, 0, 0};
  void bind(const ParamIndex& index, const std::string& effect) {
    mass = requireColumn(index, "mass", effect);
    mc_xyz[0] = requireColumn(index, "mass_com_x", effect);
    mc_xyz[1] = requireColumn(index, "mass_com_y", effect);
    mc_xyz[2] = requireColumn(index, "mass_com_z", effect);
  }
  /// Adds the columns of a force m*v applied at the centre of mass: f += m v, t += (m c) x v.
  void addForceAtCom(const Vec3& v, RegressorRef Y) const noexcept {
    Y(0, mass) += v.x();
    Y(1, mass) += v.y();
    Y(2, mass) += v.z();
    // (m c) x v = -skew(v) (m c): column j of -skew(v).
    const Mat3 minus_skew = -skew(v);
    for (int j = 0; j < 3; ++j) {
      Y(3, mc_xyz[j]) += minus_skew(0, j);
      Y(4, mc_xyz[j]) += minus_skew(1, j);
      Y(5, mc_xyz[j]) += minus_skew(2, j);
    }
  }
};

class GravityEffect final : public Effect {
 public:
  std::string name() const override { return "gravity"; }
  std::string description() const override {
    return "weight of the payload: force m g_S at the centre of mass c";
  }
  std::vector<ParamInfo> params() const override {
    return {{"mass", "kg", "payload mass m"},
            {"mass_com_x", "kg*m", "first moment m c_x"},
            {"mass_com_y", "kg*m", "first moment m c_y"},
            {"mass_com_z", "kg*m", "first moment m c_z"}};
  }
  void bind(const ParamIndex& index) override { cols_.bind(index, name()); }
  void addRegressor(const SampleContext& ctx, RegressorRef Y) const noexcept override {
    cols_.addForceAtCom(ctx.g_S, Y);
  }
  bool constantGravitySlope() const override { return true; }  // linear in g_S, nothing else
  std::unique_ptr<Effect> clone() const override { return std::make_unique<GravityEffect>(*this); }

 private:
  MassColumns cols_;
};

class TiltEffect final : public Effect {
 public:
  std::string name() const override { return "tilt"; }
  std::string description() const override {
    return "base mounted off level: R_WB = Rx(U) Ry(V) rotates gravity in B";
  }
  std::vector<ParamInfo> params() const override { return {}; }
  std::vector<std::string> requires() const override { return {"gravity"}; }
  bool estimatesTilt() const override { return true; }
  void bind(const ParamIndex& /*index*/) override {}
  void addRegressor(const SampleContext& /*ctx*/, RegressorRef /*Y*/) const noexcept override {}
  std::unique_ptr<Effect> clone() const override { return std::make_unique<TiltEffect>(*this); }
};

class LinearInertiaEffect final : public Effect {
 public:
  std::string name() const override { return "linear_inertia"; }
  std::string description() const override {
    return "inertial force of the payload moving with the sensor origin: -m a_S at c";
  }
  std::vector<ParamInfo> params() const override { return {}; }
  std::vector<std::string> requires() const override { return {"gravity"}; }
  void bind(const ParamIndex& index) override { cols_.bind(index, name()); }
  void addRegressor(const SampleContext& ctx, RegressorRef Y) const noexcept override {
    cols_.addForceAtCom(-ctx.a_S, Y);
  }
  std::unique_ptr<Effect> clone() const override {
    return std::make_unique<LinearInertiaEffect>(*this);
  }

 private:
  MassColumns cols_;
};

}  // namespace

std::unique_ptr<Effect> makeOffsetsEffect(const std::string& args) {
  rejectArgs("offsets", args);
  return std::make_unique<OffsetsEffect>();
}
std::unique_ptr<Effect> makeGravityEffect(const std::string& args) {
  rejectArgs("gravity", args);
  return std::make_unique<GravityEffect>();
}
std::unique_ptr<Effect> makeTiltEffect(const std::string& args) {
  rejectArgs("tilt", args);
  return std::make_unique<TiltEffect>();
}
std::unique_ptr<Effect> makeLinearInertiaEffect(const std::string& args) {
  rejectArgs("linear_inertia", args);
  return std::make_unique<LinearInertiaEffect>();
}

}  // namespace ftid::effects
