#pragma once
// The `rigid_body` effect (docs/effects.md): the Newton-Euler terms the paper omits.
//   force  rows, mass_com columns += -(skew(alpha_S) + skew(w_S)^2)        i.e. -alpha x (m c) - w x (w x (m c))
//   torque rows, i_s_* columns    += -(L(alpha_S) + skew(w_S) L(w_S))      i.e. -I_S alpha - w x (I_S w)
// with I_S the inertia about the S origin, L(v) the 3x6 matrix with L(v) [xx yy zz xy xz yz]^T = I v.
// Parameters: i_s_xx, i_s_yy, i_s_zz, i_s_xy, i_s_xz, i_s_yz [kg m^2] (order of docs/conventions.md).
// The inertia about the centre of mass is I_C = I_S - m (|c|^2 1 - c c^T) (parallel-axis theorem).
#include <string>

#include "ftid/common/types.hpp"

namespace ftid::effects {

/// Names of the rigid_body parameters, in the order of the 6-vector [xx, yy, zz, xy, xz, yz].
inline constexpr const char* kInertiaParamNames[6] = {"i_s_xx", "i_s_yy", "i_s_zz",
                                                      "i_s_xy", "i_s_xz", "i_s_yz"};

/// 6-vector [xx, yy, zz, xy, xz, yz] <-> symmetric 3x3.
Mat3 inertiaMatrix(const Vec6& v);
Vec6 inertiaVector(const Mat3& I);

/// The inertia tensor about the centre of mass with uncertainty and a physical-validity check.
struct InertiaAboutCom {
  Vec6 value = Vec6::Zero();      ///< I_C as [xx, yy, zz, xy, xz, yz] [kg m^2]
  Vec6 std = Vec6::Zero();        ///< standard errors (first-order propagation)
  Vec3 principal = Vec3::Zero();  ///< principal moments, ascending
  bool positive_definite = false;
  bool triangle_inequalities = false;  ///< each principal moment <= sum of the other two
  /// Same checks allowing 3 standard errors of slack (valid "within uncertainty").
  bool valid_within_uncertainty = false;
  std::string explanation;        ///< one line: what is (in)valid
};

/// From p = [m, m c_x, m c_y, m c_z, I_S (6)] and its 10x10 covariance.
InertiaAboutCom inertiaAboutCom(const Eigen::Matrix<double, 10, 1>& p,
                                const Eigen::Matrix<double, 10, 10>& covariance);

}  // namespace ftid::effects
