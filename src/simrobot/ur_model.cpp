#include "ftid/simrobot/ur_model.hpp"

#include <cctype>

#include "ftid/common/error.hpp"
#include "ur_dh_table.inc"  // generated from config/ur_dh.json (src/simrobot/CMakeLists.txt)

namespace ftid::simrobot {

RobotModel parseRobotModel(const std::string& name) {
  std::string n;
  for (char c : name) n.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  if (n == "ur10") return RobotModel::kUR10;
  if (n == "ur10e") return RobotModel::kUR10e;
  throw ConfigError("unknown robot model '" + name + "' (expected ur10 or ur10e)");
}

const DhTable& dhTable(RobotModel model) noexcept {
  static const DhTable kUr10{generated::kUr10D, generated::kUr10A, generated::kUr10Alpha};
  static const DhTable kUr10e{generated::kUr10eD, generated::kUr10eA, generated::kUr10eAlpha};
  return model == RobotModel::kUR10 ? kUr10 : kUr10e;
}

Eigen::Isometry3d forwardKinematics(RobotModel model, const JointVector& q) noexcept {
  const DhTable& dh = dhTable(model);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 6; ++i) {
    const auto k = static_cast<std::size_t>(i);
    Eigen::Isometry3d Ti = Eigen::Isometry3d::Identity();
    Ti.rotate(Eigen::AngleAxisd(q[i], Vec3::UnitZ()));
    Ti.translate(Vec3(0, 0, dh.d[k]));
    Ti.translate(Vec3(dh.a[k], 0, 0));
    Ti.rotate(Eigen::AngleAxisd(dh.alpha[k], Vec3::UnitX()));
    T = T * Ti;
  }
  return T;
}

Vec6 forwardKinematicsTcpPose(RobotModel model, const JointVector& q) {
  const Eigen::Isometry3d T = forwardKinematics(model, q);
  const Eigen::AngleAxisd aa(T.rotation());
  Vec6 pose;
  pose.head<3>() = T.translation();
  pose.tail<3>() = aa.axis() * aa.angle();
  return pose;
}

}  // namespace ftid::simrobot
