#include "ftid/model/frames.hpp"

#include <cmath>

namespace ftid::model {

Mat3 tiltRotation(double u_rad, double v_rad) noexcept {
  const double cu = std::cos(u_rad), su = std::sin(u_rad);
  const double cv = std::cos(v_rad), sv = std::sin(v_rad);
  Mat3 rx;
  rx << 1.0, 0.0, 0.0, 0.0, cu, -su, 0.0, su, cu;
  Mat3 ry;
  ry << cv, 0.0, sv, 0.0, 1.0, 0.0, -sv, 0.0, cv;
  return rx * ry;
}

Vec3 gravityInBase(double u_rad, double v_rad) noexcept {
  const Vec3 g_W(0.0, 0.0, -kStandardGravity);
  return tiltRotation(u_rad, v_rad).transpose() * g_W;
}

}  // namespace ftid::model
