#pragma once
// The `cable` effect (docs/effects.md): a cable or hose pulling the tool toward a fixed anchor,
// modelled as a linear spring of rest length 0 between an attachment point A on the tool
// (p_SA_S = a, fixed in S) and an anchor K fixed in the base (p_BK_B = p_K):
//
//   F_S = k R_BS^T (p_K - p_BS_B - R_BS a) = R_BS^T v - k R_BS^T p_BS_B - u
//   T_S = a x F_S = sum_ij P_ij e_i x (R_BS^T e_j) - u x (R_BS^T p_BS_B)
//
// with v = k p_K, u = k a and the bilinear P = a v^T relaxed to 9 free parameters, so the effect
// is linear. The constant pull v is a uniform force field in B, like gravity: its horizontal part
// is indistinguishable from a base tilt and its moment from a shift of the gravity moment, so the
// effect requires `tilt` and keeps only v_z; the rest is absorbed by the tilt (U, V) and by P.
// Identifiable with physical meaning: k and u = k a (hence the attachment point a = u / k).
#include <string>

namespace ftid::effects {

inline constexpr const char* kCableStiffnessParam = "cable_k";                 ///< [N/m]
inline constexpr const char* kCableAttachParams[3] = {"cable_ka_x", "cable_ka_y", "cable_ka_z"};  ///< k a [N]

}  // namespace ftid::effects
