// The `rigid_body` effect: tangential, centripetal and rotational inertia terms of the payload
// (include/ftid/effects/rigid_body.hpp, docs/effects.md, docs/conventions.md).
#include <Eigen/Eigenvalues>
#include <cmath>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "ftid/common/error.hpp"
#include "ftid/effects/effect.hpp"
#include "ftid/effects/rigid_body.hpp"

namespace ftid::effects {

namespace {

using RegressorRef = Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>>;

/// L(v) with L(v) * [xx yy zz xy xz yz]^T = I v.
Eigen::Matrix<double, 3, 6> inertiaLift(const Vec3& v) {
  Eigen::Matrix<double, 3, 6> L;
  L << v.x(), 0.0, 0.0, v.y(), v.z(), 0.0,  //
      0.0, v.y(), 0.0, v.x(), 0.0, v.z(),   //
      0.0, 0.0, v.z(), 0.0, v.x(), v.y();
  return L;
}

class RigidBodyEffect final : public Effect {
 public:
  std::string name() const override { return "rigid_body"; }
  std::string description() const override {
    return "full Newton-Euler payload dynamics: tangential/centripetal forces m(alpha x c + w x (w x c)) "
           "and rotational inertia I alpha + w x (I w)";
  }
  std::vector<ParamInfo> params() const override {
    return {{"i_s_xx", "kg*m^2", "inertia about the S origin, xx"},
            {"i_s_yy", "kg*m^2", "inertia about the S origin, yy"},
            {"i_s_zz", "kg*m^2", "inertia about the S origin, zz"},
            {"i_s_xy", "kg*m^2", "inertia about the S origin, xy"},
            {"i_s_xz", "kg*m^2", "inertia about the S origin, xz"},
            {"i_s_yz", "kg*m^2", "inertia about the S origin, yz"}};
  }
  std::vector<std::string> requires() const override { return {"gravity", "linear_inertia"}; }
  void bind(const ParamIndex& index) override {
    mc_[0] = requireColumn(index, "mass_com_x", name());
    mc_[1] = requireColumn(index, "mass_com_y", name());
    mc_[2] = requireColumn(index, "mass_com_z", name());
    for (int k = 0; k < 6; ++k) is_[k] = requireColumn(index, kInertiaParamNames[k], name());
  }
  void addRegressor(const SampleContext& ctx, RegressorRef Y) const noexcept override {
    // Force: -alpha x (m c) - w x (w x (m c)) = -(skew(alpha) + skew(w)^2) (m c).
    const Mat3 sw = skew(ctx.w_S);
    const Mat3 force_mc = -(skew(ctx.alpha_S) + sw * sw);
    for (int j = 0; j < 3; ++j) {
      for (int i = 0; i < 3; ++i) Y(i, mc_[j]) += force_mc(i, j);
    }
    // Torque: -I_S alpha - w x (I_S w). (The moment of the centripetal/tangential force about S is
    // contained in I_S by the parallel-axis theorem; docs/conventions.md.)
    const Eigen::Matrix<double, 3, 6> torque_is = -(inertiaLift(ctx.alpha_S) + sw * inertiaLift(ctx.w_S));
    for (int k = 0; k < 6; ++k) {
      for (int i = 0; i < 3; ++i) Y(3 + i, is_[k]) += torque_is(i, k);
    }
  }
  std::unique_ptr<Effect> clone() const override { return std::make_unique<RigidBodyEffect>(*this); }

 private:
  int mc_[3] = {0, 0, 0};
  int is_[6] = {0, 0, 0, 0, 0, 0};
};

}  // namespace

std::unique_ptr<Effect> makeRigidBodyEffect(const std::string& args) {
  if (!args.empty()) throw ConfigError("effect 'rigid_body' takes no arguments (got '" + args + "')");
  return std::make_unique<RigidBodyEffect>();
}

}  // namespace ftid::effects
