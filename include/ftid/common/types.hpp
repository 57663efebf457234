#pragma once
// Fixed-size value types shared by every module. Frames and units are in the names
// (docs/conventions.md): R_AB rotates vectors from B to A, p_AB_C is the position of B
// relative to A expressed in C, w_S is an angular velocity expressed in S.
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace ftid {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;

inline constexpr int kNumJoints = 6;
using JointVector = Eigen::Matrix<double, kNumJoints, 1>;

/// Standard gravity [m/s^2]; g_W = (0, 0, -kStandardGravity) in the world frame W.
inline constexpr double kStandardGravity = 9.80665;

/// A wrench as [fx, fy, fz, tx, ty, tz]: force [N] then moment [Nm] about the frame origin.
using Wrench = Vec6;
inline Eigen::Ref<const Vec3> forceOf(const Wrench& w) { return w.head<3>(); }
inline Eigen::Ref<const Vec3> torqueOf(const Wrench& w) { return w.tail<3>(); }

/// Names of the six wrench axes, in storage order.
inline constexpr const char* kWrenchAxisNames[6] = {"fx", "fy", "fz", "tx", "ty", "tz"};

/// Skew-symmetric matrix: skew(a) * b == a.cross(b).
inline Mat3 skew(const Vec3& a) {
  Mat3 s;
  s << 0.0, -a.z(), a.y(), a.z(), 0.0, -a.x(), -a.y(), a.x(), 0.0;
  return s;
}

}  // namespace ftid
