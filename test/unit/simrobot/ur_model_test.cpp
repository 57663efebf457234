// The simulator's DH forward kinematics (compiled from config/ur_dh.json) against KDL on the
// URDFs that tools/gen_ur_urdf.py generates from the same table: two independent routes
// (hand-written DH products vs urdfdom -> KDL chain of URDF joint origins).
#include <gtest/gtest.h>

#include <random>
#include <string>

#include "ftid/model/kinematics.hpp"
#include "ftid/simrobot/ur_model.hpp"
#include "test_paths.hpp"

namespace sim = ftid::simrobot;
using ftid::JointVector;

namespace {

void compareWithKdl(sim::RobotModel model, const std::string& urdf) {
  const auto kdl = ftid::model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/") + urdf);
  std::mt19937_64 rng(20261202);
  std::uniform_real_distribution<double> angle(-6.283185307179586, 6.283185307179586);
  for (int n = 0; n < 500; ++n) {
    JointVector q;
    for (int i = 0; i < 6; ++i) q[i] = angle(rng);
    const Eigen::Isometry3d X_dh = sim::forwardKinematics(model, q);
    const Eigen::Isometry3d X_kdl = kdl.computeFlangePose(q);
    ASSERT_LT((X_dh.translation() - X_kdl.translation()).cwiseAbs().maxCoeff(), 1e-12)
        << urdf << " q = " << q.transpose();
    ASSERT_LT((X_dh.linear() - X_kdl.linear()).cwiseAbs().maxCoeff(), 1e-12) << urdf << " q = " << q.transpose();
    // actual_TCP_pose: the same pose as a rotation vector.
    const ftid::Vec6 pose = sim::forwardKinematicsTcpPose(model, q);
    const Eigen::Vector3d rv = pose.tail<3>();
    const Eigen::Matrix3d R = rv.norm() > 0 ? Eigen::AngleAxisd(rv.norm(), rv.normalized()).toRotationMatrix()
                                            : Eigen::Matrix3d::Identity();
    ASSERT_LT((R - X_kdl.linear()).cwiseAbs().maxCoeff(), 1e-9) << urdf << " q = " << q.transpose();
    ASSERT_LT((pose.head<3>() - X_kdl.translation()).cwiseAbs().maxCoeff(), 1e-12);
  }
}

}  // namespace

TEST(SimKinematics, MatchesKdlOnTheGeneratedUr10Urdf) { compareWithKdl(sim::RobotModel::kUR10, "ur10.urdf"); }

TEST(SimKinematics, MatchesKdlOnTheGeneratedUr10eUrdf) { compareWithKdl(sim::RobotModel::kUR10e, "ur10e.urdf"); }

TEST(SimKinematics, TableIsConventionsMdsUr10Row) {
  // docs/conventions.md's table (the published UR10 values), and the flange pin at q = 0.
  const auto& dh = sim::dhTable(sim::RobotModel::kUR10);
  EXPECT_EQ(dh.d[0], 0.1273);
  EXPECT_EQ(dh.a[1], -0.612);
  EXPECT_EQ(dh.a[2], -0.5723);
  EXPECT_EQ(dh.d[3], 0.163941);
  EXPECT_EQ(dh.d[4], 0.1157);
  EXPECT_EQ(dh.d[5], 0.0922);
  const Eigen::Vector3d p_BF = sim::forwardKinematics(sim::RobotModel::kUR10, JointVector::Zero()).translation();
  EXPECT_LT((p_BF - Eigen::Vector3d(-1.1843, -0.256141, 0.0116)).cwiseAbs().maxCoeff(), 1e-12);
}
