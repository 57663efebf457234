#pragma once
// The UR robot models the simulator knows: their DH table and forward kinematics.
//
// The DH parameters are compiled in from config/ur_dh.json, the one UR DH table of the project
// (tools/gen_ur_urdf.py generates config/ur10.urdf and config/ur10e.urdf from the same file;
// docs/architecture.md says why it is a build-time header and not a run-time file). Convention
// (docs/conventions.md): T_i = Rz(q_i) Tz(d_i) Tx(a_i) Rx(alpha_i), X_BF = T_1 ... T_6.
#include <array>
#include <cstdint>
#include <string>

#include <Eigen/Geometry>

#include "ftid/common/types.hpp"

namespace ftid::simrobot {

enum class RobotModel : std::uint8_t {
  kUR10,   ///< CB3, software 3.15.8.106339, 125 Hz
  kUR10e,  ///< e-Series, software 5.11.1.108318, 500 Hz
};
/// "ur10" / "ur10e" (case-insensitive). Throws ConfigError otherwise.
RobotModel parseRobotModel(const std::string& name);

/// Standard-DH parameters of one model [m, rad].
struct DhTable {
  std::array<double, 6> d{};
  std::array<double, 6> a{};
  std::array<double, 6> alpha{};
};
/// The table of `model`, as read from config/ur_dh.json at build time.
const DhTable& dhTable(RobotModel model) noexcept;

/// X_BF: the flange (tool0, DH frame 6) in the controller base frame B at joint angles q.
Eigen::Isometry3d forwardKinematics(RobotModel model, const JointVector& q) noexcept;

/// UR DH forward kinematics: actual_TCP_pose = [x, y, z, rx, ry, rz] in the controller base frame
/// (zero TCP offset; rotation vector). Exposed for tests.
Vec6 forwardKinematicsTcpPose(RobotModel model, const JointVector& q);

}  // namespace ftid::simrobot
