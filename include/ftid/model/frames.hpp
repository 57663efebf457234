#pragma once
// Frames (docs/conventions.md is the single source of truth):
//   W  world, z up, gravity g_W = (0, 0, -kStandardGravity)
//   B  robot controller Base frame (UR DH base; RTDE poses are in B)
//   F  flange (UR tool0 = DH frame 6)
//   S  sensor frame, X_FS fixed from config (default identity)
//   C  payload centre of mass (p_SC_S = centre of mass in S)
// Base tilt (paper Eq. 10): R_WB = Rx(U) * Ry(V).
#include "ftid/common/types.hpp"

namespace ftid::model {

/// R_WB for base tilt angles U (about x) and V (about y), in radians: Rx(U) * Ry(V).
Mat3 tiltRotation(double u_rad, double v_rad) noexcept;

/// Gravity expressed in B for the given tilt: R_WB^T * g_W.
Vec3 gravityInBase(double u_rad, double v_rad) noexcept;

/// Gravity expressed in S: R_BS^T * R_WB^T * g_W.
inline Vec3 gravityInSensor(const Mat3& R_BS, double u_rad, double v_rad) noexcept {
  return R_BS.transpose() * gravityInBase(u_rad, v_rad);
}

}  // namespace ftid::model
