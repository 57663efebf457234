#pragma once
// Robot kinematics: URDF (urdfdom) -> KDL chain -> pose, velocity and acceleration of the sensor
// frame S from joint positions, velocities and accelerations.
//
// Identities (tested against closed-form DH and finite differences, test/unit/model):
//   R_BS, p_BS_B  = FK(q) * X_FS
//   w_S           = R_BS^T * d/dt(R_BS) as a vector (angular velocity of S relative to B, in S)
//   alpha_S       = d/dt(w_S_in_B) expressed in S
//   a_S           = R_BS^T * d^2/dt^2 (p_BS_B)   (classical acceleration of the S origin, no gravity)
#include <array>
#include <cstddef>
#include <memory>
#include <string>
#include <string_view>

#include "ftid/common/types.hpp"

namespace ftid::model {

/// Kinematic state of the sensor frame S relative to the (inertial) robot base B.
struct SensorMotion {
  Mat3 R_BS = Mat3::Identity();  ///< orientation of S in B
  Vec3 p_BS_B = Vec3::Zero();    ///< position of the S origin in B [m]
  Vec3 w_S = Vec3::Zero();       ///< angular velocity of S, expressed in S [rad/s]
  Vec3 alpha_S = Vec3::Zero();   ///< angular acceleration of S, expressed in S [rad/s^2]
  Vec3 a_S = Vec3::Zero();       ///< linear acceleration of the S origin, expressed in S [m/s^2]
};

struct JointLimits {
  JointVector lower = JointVector::Constant(-2.0 * 3.141592653589793);  ///< [rad]
  JointVector upper = JointVector::Constant(2.0 * 3.141592653589793);   ///< [rad]
  JointVector velocity = JointVector::Constant(3.14);                   ///< [rad/s]
  JointVector acceleration = JointVector::Constant(40.0);               ///< [rad/s^2] (not in URDF)
};

/// Deepest element nesting of an XML text (a cheap scan: comments, CDATA, declarations and quoted
/// attribute values are skipped). fromUrdfString refuses more than kMaxUrdfDepth levels before
/// the XML parser runs, because the parser recurses once per level (a deeply nested file would
/// overflow the stack).
std::size_t xmlNestingDepth(std::string_view xml);
inline constexpr std::size_t kMaxUrdfDepth = 64;

class RobotKinematics {
 public:
  /// Loads a 6-joint serial chain from base_link to tip_link. Throws ConfigError naming the file
  /// (and urdfdom's message) if the file is missing, malformed, or the chain is not 6 revolute joints.
  static RobotKinematics fromUrdfFile(const std::string& path, const std::string& base_link = "base",
                                      const std::string& tip_link = "tool0");
  static RobotKinematics fromUrdfString(const std::string& xml, const std::string& base_link = "base",
                                        const std::string& tip_link = "tool0",
                                        const std::string& source_name = "<string>");

  RobotKinematics(const RobotKinematics&);
  RobotKinematics& operator=(const RobotKinematics&);
  RobotKinematics(RobotKinematics&&) noexcept;
  RobotKinematics& operator=(RobotKinematics&&) noexcept;
  ~RobotKinematics();

  /// Fixed sensor mount X_FS: orientation R_FS and position p_FS_F of S in the flange frame F.
  void setSensorMount(const Mat3& R_FS, const Vec3& p_FS_F);

  /// Sensor-frame motion. Real-time safe: no allocation, no exceptions (workspace preallocated).
  /// Not thread-safe on one instance (each thread uses its own copy).
  SensorMotion computeSensorMotion(const JointVector& q, const JointVector& qd,
                                   const JointVector& qdd) const noexcept;

  /// Flange pose X_BF (rotation R_BF, translation p_BF_B).
  Eigen::Isometry3d computeFlangePose(const JointVector& q) const noexcept;

  /// Sensor pose X_BS = X_BF(q) * X_FS (allocation-free).
  Eigen::Isometry3d computeSensorPose(const JointVector& q) const noexcept;

  /// The sensor mount X_FS set by setSensorMount (identity by default).
  Eigen::Isometry3d sensorMount() const noexcept;

  const JointLimits& limits() const noexcept;
  /// Names of the six movable joints, base to tip (e.g. shoulder_pan_joint ... wrist_3_joint).
  const std::array<std::string, kNumJoints>& jointNames() const noexcept;
  const std::string& sourceName() const noexcept;

 private:
  struct Impl;
  explicit RobotKinematics(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace ftid::model
