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

Mat3 inertiaMatrix(const Vec6& v) {
  Mat3 I;
  I << v(0), v(3), v(4), v(3), v(1), v(5), v(4), v(5), v(2);
  return I;
}

Vec6 inertiaVector(const Mat3& I) {
  Vec6 v;
  v << I(0, 0), I(1, 1), I(2, 2), I(0, 1), I(0, 2), I(1, 2);
  return v;
}

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

/// I_C(p) as a 6-vector, p = [m, mc(3), I_S(6)].
Vec6 comInertia(const Eigen::Matrix<double, 10, 1>& p) {
  const double m = p(0);
  const Vec3 mc = p.segment<3>(1);
  const Mat3 shift = (mc.squaredNorm() * Mat3::Identity() - mc * mc.transpose()) / m;
  return inertiaVector(inertiaMatrix(p.tail<6>()) - shift);
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

InertiaAboutCom inertiaAboutCom(const Eigen::Matrix<double, 10, 1>& p,
                                const Eigen::Matrix<double, 10, 10>& covariance) {
  if (!(p(0) > 0.0)) throw IdentificationError("inertia about the centre of mass needs a positive mass");
  InertiaAboutCom out;
  out.value = comInertia(p);
  // First-order propagation with a central-difference Jacobian (the map is smooth for m > 0).
  Eigen::Matrix<double, 6, 10> J;
  for (int k = 0; k < 10; ++k) {
    const double h = 1e-6 * std::max(1.0, std::abs(p(k)));
    Eigen::Matrix<double, 10, 1> pp = p, pm = p;
    pp(k) += h;
    pm(k) -= h;
    J.col(k) = (comInertia(pp) - comInertia(pm)) / (2.0 * h);
  }
  const Mat6 cov = J * covariance * J.transpose();
  for (int k = 0; k < 6; ++k) out.std(k) = std::sqrt(std::max(0.0, cov(k, k)));
  Eigen::SelfAdjointEigenSolver<Mat3> eig(inertiaMatrix(out.value));
  out.principal = eig.eigenvalues();  // ascending
  const Vec3& l = out.principal;
  out.positive_definite = l(0) > 0.0;
  out.triangle_inequalities = l(2) <= l(0) + l(1);
  // Slack: 3 std of the largest diagonal uncertainty (principal moments are linear in I_C to first order).
  const double slack = 3.0 * out.std.head<3>().maxCoeff() + 3.0 * out.std.tail<3>().maxCoeff();
  out.valid_within_uncertainty = l(0) > -slack && l(2) <= l(0) + l(1) + slack;
  std::ostringstream msg;
  msg.precision(4);
  msg << "principal moments " << l(0) << ", " << l(1) << ", " << l(2) << " kg*m^2: ";
  if (out.positive_definite && out.triangle_inequalities) {
    msg << "physically valid (positive definite, triangle inequalities hold)";
  } else {
    if (!out.positive_definite) msg << "not positive definite; ";
    if (!out.triangle_inequalities) msg << "triangle inequality violated; ";
    msg << (out.valid_within_uncertainty ? "consistent with a valid tensor within 3 standard errors"
                                         : "physically impossible beyond the uncertainty");
  }
  out.explanation = msg.str();
  return out;
}

std::unique_ptr<Effect> makeRigidBodyEffect(const std::string& args) {
  if (!args.empty()) throw ConfigError("effect 'rigid_body' takes no arguments (got '" + args + "')");
  return std::make_unique<RigidBodyEffect>();
}

}  // namespace ftid::effects
