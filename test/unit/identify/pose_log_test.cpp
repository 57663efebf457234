// Pose-based logs (docs/log-format.md "Pose logs"): the same run written with joint angles and
// with the pose of S in B gives the same parameters.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "ftid/common/error.hpp"
#include "ftid/samples/context.hpp"
#include "ftid/identify/offline.hpp"
#include "ftid/logio/log.hpp"
#include "paper_cell.hpp"
#include "test_paths.hpp"

namespace ftid::identify {
namespace {

std::string scratch(const std::string& name) {
  return ::testing::TempDir() + "ftid_pose_" + std::to_string(::getpid()) + "_" + name;
}

/// The paper cell with full rigid-body physics and sensor noise (independent simulator).
logio::LogData simulatedRun() {
  sim::CellSimConfig cfg = test::paperConfig(true, 11);
  cfg.full_rigid_body = true;
  return sim::CellSim(cfg).run();
}

enum class Rotation { kQuaternion, kRotationVector };
struct PoseOptions {
  Rotation rotation = Rotation::kQuaternion;
  bool position = true;
  bool motion_columns = true;   ///< exact kin_w*, kin_al*, kin_a* columns
  bool wrench_in_base = false;  ///< wrench columns rotated into B
};

/// The same run as a pose log: t, the pose of S in B (from the kinematics of the joint log), the
/// wrench, optionally the exact motion columns.
logio::LogData asPoseLog(const logio::LogData& joints, const PoseOptions& o) {
  const samples::ContextSet c = samples::buildContexts(joints, test::ur10());
  logio::LogData p;
  p.source = joints.source;
  p.has_joints = false;
  p.has_wrench = true;
  p.samples = joints.samples;
  for (auto& s : p.samples) {
    s.q.setZero();
    s.qd.setZero();
    s.qdd.setZero();
  }
  auto add = [&](const std::string& name, auto value) {
    p.extra_names.push_back(name);
    p.extra_columns.emplace_back();
    for (const auto& ctx : c.samples) p.extra_columns.back().push_back(value(ctx));
  };
  if (o.position) {
    for (int k = 0; k < 3; ++k) add(std::string("p") + "xyz"[k], [k](const SampleContext& x) { return x.p_BS_B(k); });
  }
  if (o.rotation == Rotation::kQuaternion) {
    for (int k = 0; k < 4; ++k) {
      add(std::string("q") + "xyzw"[k], [k](const SampleContext& x) {
        const Eigen::Quaterniond q(x.R_BS);
        return k == 0 ? q.x() : k == 1 ? q.y() : k == 2 ? q.z() : q.w();
      });
    }
  } else {
    for (int k = 0; k < 3; ++k) {
      add(std::string("r") + "xyz"[k], [k](const SampleContext& x) {
        const Eigen::AngleAxisd aa(x.R_BS);
        return (aa.angle() * aa.axis())(k);
      });
    }
  }
  if (o.motion_columns) {
    for (int k = 0; k < 3; ++k) add(std::string("kin_w") + "xyz"[k], [k](const SampleContext& x) { return x.w_S(k); });
    for (int k = 0; k < 3; ++k) add(std::string("kin_al") + "xyz"[k], [k](const SampleContext& x) { return x.alpha_S(k); });
    for (int k = 0; k < 3; ++k) add(std::string("kin_a") + "xyz"[k], [k](const SampleContext& x) { return x.a_S(k); });
  }
  if (o.wrench_in_base) {
    for (std::size_t i = 0; i < p.samples.size(); ++i) {
      const Mat3& R = c.samples[i].R_BS;
      p.samples[i].wrench_S.head<3>() = R * joints.samples[i].wrench_S.head<3>();
      p.samples[i].wrench_S.tail<3>() = R * joints.samples[i].wrench_S.tail<3>();
    }
  }
  return p;
}

ParameterSet identifyFile(const logio::LogData& log, const std::string& name, const std::string& model,
                          bool wrench_in_base = false) {
  const std::string path = scratch(name);
  logio::writeLog(path, log);
  IdentifyRequest r;
  r.log_path = path;
  r.model = model;
  r.robot_urdf = ftid::test::sourcePath("/config/ur10.urdf");
  r.context.wrench_in_base = wrench_in_base;
  ParameterSet set;
  try {
    set = identifyLogFile(r);
  } catch (...) {
    std::remove(path.c_str());
    throw;
  }
  std::remove(path.c_str());
  return set;
}

void expectSameParameters(const ParameterSet& a, const ParameterSet& b, double tol) {
  ASSERT_EQ(a.params.size(), b.params.size());
  for (const auto& p : a.params) {
    const NamedValue* q = b.find(p.name);
    ASSERT_NE(q, nullptr) << p.name;
    EXPECT_NEAR(p.value, q->value, tol) << p.name;
  }
  EXPECT_NEAR(a.tilt_u_rad, b.tilt_u_rad, tol);
  EXPECT_NEAR(a.tilt_v_rad, b.tilt_v_rad, tol);
}

TEST(PoseLog, QuaternionPoseGivesTheJointLogsParameters) {
  const logio::LogData joints = simulatedRun();
  for (const std::string model : {"paper", "paper+rigid_body"}) {
    const ParameterSet a = identifyFile(joints, "joints.csv", model);
    const ParameterSet b = identifyFile(asPoseLog(joints, {}), "quat.csv", model);
    SCOPED_TRACE(model);
    expectSameParameters(a, b, 1e-9);
  }
  // The paper's own (two-stage) method as well.
  const ParameterSet a = identifyFile(joints, "joints_paper.csv", "");
  const ParameterSet b = identifyFile(asPoseLog(joints, {}), "quat_paper.csv", "");
  expectSameParameters(a, b, 1e-9);
}

TEST(PoseLog, RotationVectorAndBaseFrameWrenchGiveTheSameParameters) {
  const logio::LogData joints = simulatedRun();
  const ParameterSet a = identifyFile(joints, "joints2.csv", "paper+rigid_body");
  PoseOptions o;
  o.rotation = Rotation::kRotationVector;
  o.wrench_in_base = true;
  const ParameterSet b = identifyFile(asPoseLog(joints, o), "rotvec_base.csv", "paper+rigid_body", true);
  expectSameParameters(a, b, 1e-9);
  // Read as if it were in the sensor frame, the base-frame wrench gives something else.
  EXPECT_GT(std::abs(identifyFile(asPoseLog(joints, o), "rotvec_wrong.csv", "paper").find("mass")->value -
                     a.find("mass")->value),
            1e-3);
}

TEST(PoseLog, FiniteDifferencesWithoutMotionColumnsApproximateTheMotion) {
  const logio::LogData joints = simulatedRun();
  const ParameterSet a = identifyFile(joints, "joints3.csv", "paper+rigid_body");
  PoseOptions o;
  o.motion_columns = false;
  const ParameterSet b = identifyFile(asPoseLog(joints, o), "fd.csv", "paper+rigid_body");
  // Smoothed finite differences of a 125 Hz pose: close, not identical.
  EXPECT_NEAR(b.find("mass")->value, a.find("mass")->value, 0.005 * a.find("mass")->value);
  for (const char* c : {"com_x", "com_y", "com_z"}) EXPECT_NEAR(b.find(c)->value, a.find(c)->value, 1e-3) << c;
  EXPECT_NEAR(b.tilt_u_rad, a.tilt_u_rad, 2e-3);
  EXPECT_NEAR(b.tilt_v_rad, a.tilt_v_rad, 2e-3);
}

TEST(PoseLog, EffectsThatNeedJointAnglesSaySo) {
  const logio::LogData joints = simulatedRun();
  try {
    identifyFile(asPoseLog(joints, {}), "harmonic.csv", "paper+harmonic(q6,1)");
    FAIL() << "expected IdentificationError";
  } catch (const IdentificationError& e) {
    EXPECT_NE(std::string(e.what()).find("harmonic(q6,1)"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no joint angles"), std::string::npos) << e.what();
  }
}

TEST(PoseLog, ALogWithNeitherJointsNorPoseNamesBoth) {
  const std::string path = scratch("neither.csv");
  {
    std::FILE* f = std::fopen(path.c_str(), "w");
    ASSERT_NE(f, nullptr);
    std::fputs("t,px,py,pz,fx,fy,fz,tx,ty,tz\n0,0,0,0,1,2,3,4,5,6\n", f);
    std::fclose(f);
  }
  try {
    logio::readLog(path);
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("qx,qy,qz,qw or rx,ry,rz"), std::string::npos) << e.what();
  }
  std::remove(path.c_str());
}

TEST(PoseLog, QuaternionThatIsNotUnitIsRejected) {
  logio::LogData p = asPoseLog(simulatedRun(), {});
  for (const char* name : {"qx", "qy", "qz", "qw"}) {
    const int k = p.extraIndex(name);
    ASSERT_GE(k, 0);
    p.extra_columns[static_cast<std::size_t>(k)][5] *= 1.01;  // |q| = 1.01
  }
  EXPECT_THROW(samples::buildContexts(p, test::ur10()), DataError);
}

}  // namespace
}  // namespace ftid::identify
