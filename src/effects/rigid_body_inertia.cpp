// Inertia-tensor helpers of the rigid_body effect (include/ftid/effects/rigid_body.hpp): pure math,
// in their own file so parameter-file validation (and its fuzz target) needs no effect machinery.
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include "ftid/common/error.hpp"
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

/// I_C(p) as a 6-vector, p = [m, mc(3), I_S(6)].
Vec6 comInertia(const Eigen::Matrix<double, 10, 1>& p) {
  const double m = p(0);
  const Vec3 mc = p.segment<3>(1);
  const Mat3 shift = (mc.squaredNorm() * Mat3::Identity() - mc * mc.transpose()) / m;
  return inertiaVector(inertiaMatrix(p.tail<6>()) - shift);
}

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

}  // namespace ftid::effects
