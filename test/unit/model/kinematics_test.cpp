// Kinematics checked against an independent closed-form DH product (written here), the FK test
// vectors (docs/robot.md: UR DH forward kinematics of actual_q), and finite differences of FK.
#include <sys/stat.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "ftid/common/error.hpp"
#include "ftid/model/kinematics.hpp"
#include "test_paths.hpp"
#ifdef FTID_HAVE_ALLOC_COUNTER
#include "alloc_counter.hpp"
#endif

namespace ftid::model {
namespace {

constexpr double kPi = 3.141592653589793;

struct Dh {
  double d[6];
  double a[6];
};
const Dh kUr10{{0.1273, 0, 0, 0.163941, 0.1157, 0.0922}, {0, -0.612, -0.5723, 0, 0, 0}};
const Dh kUr10e{{0.1807, 0, 0, 0.17415, 0.11985, 0.11655}, {0, -0.6127, -0.57155, 0, 0, 0}};
const double kAlpha[6] = {kPi / 2, 0, 0, kPi / 2, -kPi / 2, 0};

// Standard DH, T_i = Rz(q) Tz(d) Tx(a) Rx(alpha), the classical closed-form matrix.
Eigen::Matrix4d dhFk(const Dh& dh, const JointVector& q) {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  for (int i = 0; i < 6; ++i) {
    const double ct = std::cos(q[i]), st = std::sin(q[i]);
    const double ca = std::cos(kAlpha[i]), sa = std::sin(kAlpha[i]);
    Eigen::Matrix4d Ti;
    Ti << ct, -st * ca, st * sa, dh.a[i] * ct,
          st, ct * ca, -ct * sa, dh.a[i] * st,
          0, sa, ca, dh.d[i],
          0, 0, 0, 1;
    T = T * Ti;
  }
  return T;
}

std::string urdfPath(const char* name) { return ftid::test::sourcePath("/config/") + name; }

class KinematicsBothRobots : public ::testing::TestWithParam<int> {};

TEST_P(KinematicsBothRobots, MatchesClosedFormDhForRandomPoses) {
  const bool e = GetParam() == 1;
  const RobotKinematics kin = RobotKinematics::fromUrdfFile(urdfPath(e ? "ur10e.urdf" : "ur10.urdf"));
  const Dh& dh = e ? kUr10e : kUr10;
  std::mt19937_64 rng(20240611 + static_cast<unsigned>(GetParam()));
  std::uniform_real_distribution<double> U(-2 * kPi, 2 * kPi);
  for (int trial = 0; trial < 300; ++trial) {
    JointVector q;
    for (int i = 0; i < 6; ++i) q[i] = U(rng);
    const Eigen::Matrix4d T = dhFk(dh, q);
    const Eigen::Isometry3d X = kin.computeFlangePose(q);
    EXPECT_LT((X.translation() - T.block<3, 1>(0, 3)).norm(), 1e-12) << "trial " << trial;
    EXPECT_LT((X.linear() - T.block<3, 3>(0, 0)).norm(), 1e-12) << "trial " << trial;
    const SensorMotion m = kin.computeSensorMotion(q, JointVector::Zero(), JointVector::Zero());
    EXPECT_LT((m.p_BS_B - T.block<3, 1>(0, 3)).norm(), 1e-12);
    EXPECT_LT((m.R_BS - T.block<3, 3>(0, 0)).norm(), 1e-12);
    EXPECT_LT(m.w_S.norm() + m.alpha_S.norm() + m.a_S.norm(), 1e-12);
  }
}

std::string robotName(const ::testing::TestParamInfo<int>& p) { return p.param == 1 ? "UR10e" : "UR10"; }
INSTANTIATE_TEST_SUITE_P(Robots, KinematicsBothRobots, ::testing::Values(0, 1), robotName);

TEST(Kinematics, Ur10FlangeAtZeroIsPinned) {
  const RobotKinematics kin = RobotKinematics::fromUrdfFile(urdfPath("ur10.urdf"));
  const Vec3 p = kin.computeFlangePose(JointVector::Zero()).translation();
  EXPECT_NEAR(p.x(), -1.1843, 1e-9);
  EXPECT_NEAR(p.y(), -0.256141, 1e-9);
  EXPECT_NEAR(p.z(), 0.0116, 1e-9);
}

// Hand-computed test vectors (positions to 1e-6 m, rotation vectors as printed).
struct FkVector {
  const char* urdf;
  double q[6];
  double p[3];
  double rotvec[3];
};
TEST(Kinematics, ReferenceFkVectors) {
  const FkVector vectors[] = {
      {"ur10.urdf", {0, 0, 0, 0, 0, 0}, {-1.1843, -0.256141, 0.0116}, {1.570796, 0, 0}},
      {"ur10.urdf", {0, -kPi / 2, 0, -kPi / 2, 0, 0}, {0, -0.256141, 1.4273}, {0, -2.221441, 2.221441}},
      {"ur10.urdf", {0.1, -1.2, 1.3, -1.7, -1.57, 0.4}, {-0.888629, -0.253998, 0.551791}, {-2.516809, -1.855957, 0.03991}},
      {"ur10e.urdf", {0, 0, 0, 0, 0, 0}, {-1.18425, -0.2907, 0.06085}, {1.570796, 0, 0}},
      {"ur10e.urdf", {0, -kPi / 2, 0, -kPi / 2, 0, 0}, {0, -0.2907, 1.4848}, {0, -2.221441, 2.221441}},
  };
  for (const auto& v : vectors) {
    const RobotKinematics kin = RobotKinematics::fromUrdfFile(urdfPath(v.urdf));
    JointVector q;
    for (int i = 0; i < 6; ++i) q[i] = v.q[i];
    const Eigen::Isometry3d X = kin.computeFlangePose(q);
    const Vec3 p_expected(v.p[0], v.p[1], v.p[2]);
    EXPECT_LT((X.translation() - p_expected).norm(), 2e-6) << v.urdf << " q1=" << v.q[1];
    // Compare as rotation matrices (a rotation vector of angle pi has two spellings).
    const Vec3 rv(v.rotvec[0], v.rotvec[1], v.rotvec[2]);
    const Mat3 R_expected = Eigen::AngleAxisd(rv.norm(), rv.normalized()).toRotationMatrix();
    EXPECT_LT((X.linear() - R_expected).norm(), 1e-5) << v.urdf << " q1=" << v.q[1];
  }
}

TEST(Kinematics, JointNamesAndLimitsComeFromTheUrdf) {
  const RobotKinematics kin = RobotKinematics::fromUrdfFile(urdfPath("ur10.urdf"));
  EXPECT_EQ(kin.jointNames()[0], "shoulder_pan_joint");
  EXPECT_EQ(kin.jointNames()[5], "wrist_3_joint");
  const double v[6] = {2.094, 2.094, 3.142, 3.142, 3.142, 3.142};
  for (int i = 0; i < 6; ++i) {
    EXPECT_DOUBLE_EQ(kin.limits().velocity[i], v[i]);
    EXPECT_NEAR(kin.limits().lower[i], -2 * kPi, 1e-12);
    EXPECT_NEAR(kin.limits().upper[i], 2 * kPi, 1e-12);
  }
  EXPECT_EQ(kin.sourceName(), urdfPath("ur10.urdf"));
}

// A smooth joint trajectory with analytic derivatives (independent of ftid::trajectory).
struct Sines {
  JointVector amp, freq, phase, centre;
  void at(double t, JointVector& q, JointVector& qd, JointVector& qdd) const {
    for (int i = 0; i < 6; ++i) {
      const double s = std::sin(freq[i] * t + phase[i]), c = std::cos(freq[i] * t + phase[i]);
      q[i] = centre[i] + amp[i] * s;
      qd[i] = amp[i] * freq[i] * c;
      qdd[i] = -amp[i] * freq[i] * freq[i] * s;
    }
  }
  JointVector q(double t) const {
    JointVector a, b, c;
    at(t, a, b, c);
    return a;
  }
};

Vec3 vee(const Mat3& W) { return 0.5 * Vec3(W(2, 1) - W(1, 2), W(0, 2) - W(2, 0), W(1, 0) - W(0, 1)); }

TEST(Kinematics, MotionMatchesFiniteDifferencesOfFk) {
  for (const char* file : {"ur10.urdf", "ur10e.urdf"}) {
    RobotKinematics kin = RobotKinematics::fromUrdfFile(urdfPath(file));
    // A non-trivial sensor mount, so the offset point's acceleration terms are exercised.
    const Mat3 R_FS = Eigen::AngleAxisd(0.7, Vec3(0.3, -1.0, 0.5).normalized()).toRotationMatrix();
    kin.setSensorMount(R_FS, Vec3(0.02, -0.03, 0.08));
    Sines s;
    s.amp << 0.8, 0.6, 0.9, 1.1, 1.0, 1.3;
    s.freq << 1.1, 0.7, 1.9, 2.3, 1.7, 2.9;
    s.phase << 0.1, 0.5, -0.3, 1.2, 0.4, -0.8;
    s.centre << 0.2, -1.4, 1.5, -1.2, -1.5, 0.3;
    auto pose = [&](double t) { return kin.computeSensorPose(s.q(t)); };
    auto w_B = [&](double t) {  // angular velocity in B from dR/dt R^T
      const double h = 1e-5;
      const Mat3 Rd = (pose(t + h).linear() - pose(t - h).linear()) / (2 * h);
      return vee(Rd * pose(t).linear().transpose());
    };
    for (double t : {0.0, 0.37, 1.21, 2.05, 3.3}) {
      JointVector q, qd, qdd;
      s.at(t, q, qd, qdd);
      const SensorMotion m = kin.computeSensorMotion(q, qd, qdd);
      const Eigen::Isometry3d X = pose(t);
      EXPECT_LT((m.R_BS - X.linear()).norm(), 1e-12);
      EXPECT_LT((m.p_BS_B - X.translation()).norm(), 1e-12);
      const Mat3 R = X.linear();
      const Vec3 w_fd = R.transpose() * w_B(t);
      const double h2 = 1e-3;
      const Vec3 alpha_fd = R.transpose() * (w_B(t + h2) - w_B(t - h2)) / (2 * h2);
      const Vec3 a_fd =
          R.transpose() * (pose(t + h2).translation() - 2 * X.translation() + pose(t - h2).translation()) / (h2 * h2);
      EXPECT_LT((m.w_S - w_fd).norm(), 1e-7) << file << " t=" << t;
      EXPECT_LT((m.alpha_S - alpha_fd).norm(), 1e-4) << file << " t=" << t;
      EXPECT_LT((m.a_S - a_fd).norm(), 1e-4) << file << " t=" << t;
      EXPECT_GT(m.alpha_S.norm(), 1.0);  // the check is not vacuous
      EXPECT_GT(m.a_S.norm(), 0.5);
    }
  }
}

TEST(Kinematics, SensorMountComposesWithFlangePose) {
  RobotKinematics kin = RobotKinematics::fromUrdfFile(urdfPath("ur10.urdf"));
  const Mat3 R_FS = Eigen::AngleAxisd(0.4, Vec3::UnitZ()).toRotationMatrix();
  const Vec3 p_FS(0.0, 0.01, 0.05);
  RobotKinematics copy = kin;
  copy.setSensorMount(R_FS, p_FS);
  JointVector q;
  q << 0.3, -1.0, 1.2, -0.5, 0.7, 2.0;
  const Eigen::Isometry3d X_BF = kin.computeFlangePose(q);
  const SensorMotion m = copy.computeSensorMotion(q, JointVector::Zero(), JointVector::Zero());
  EXPECT_LT((m.R_BS - X_BF.linear() * R_FS).norm(), 1e-12);
  EXPECT_LT((m.p_BS_B - (X_BF.translation() + X_BF.linear() * p_FS)).norm(), 1e-12);
  // The original is unaffected by the copy's mount.
  EXPECT_LT((kin.computeSensorPose(q).matrix() - X_BF.matrix()).norm(), 1e-15);
  EXPECT_LT((copy.sensorMount().translation() - p_FS).norm(), 1e-15);
}

#ifdef FTID_HAVE_ALLOC_COUNTER
TEST(Kinematics, ComputeSensorMotionDoesNotAllocate) {
  RobotKinematics kin = RobotKinematics::fromUrdfFile(urdfPath("ur10.urdf"));
  kin.setSensorMount(Mat3::Identity(), Vec3(0, 0, 0.05));
  JointVector q, qd, qdd;
  q << 0.1, -1.2, 1.3, -1.7, -1.57, 0.4;
  qd.setConstant(0.3);
  qdd.setConstant(-0.7);
  double sink = 0.0;
  {
    ftid::test::ScopedAllocationCounter counter;
    for (int i = 0; i < 100; ++i) {
      q[0] += 0.01;
      const SensorMotion m = kin.computeSensorMotion(q, qd, qdd);
      sink += m.a_S.x() + kin.computeFlangePose(q).translation().x();
    }
    EXPECT_EQ(counter.count(), 0u);
  }
  EXPECT_TRUE(std::isfinite(sink));
  // The counter itself works (guards against a vacuous pass).
  ftid::test::ScopedAllocationCounter c2;
  auto* p = new std::string(100, 'x');
  delete p;
  EXPECT_GT(c2.count(), 0u);
}
#endif

// --- Bad URDFs --------------------------------------------------------------------------------

std::string writeTemp(const std::string& name, const std::string& text) {
  const std::string path = ftid::test::binaryPath("/") + name;
  std::ofstream(path) << text;
  return path;
}

void expectConfigError(const std::string& path, const std::string& fragment) {
  try {
    (void)RobotKinematics::fromUrdfFile(path);
    FAIL() << "no ConfigError for " << path;
  } catch (const ConfigError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    EXPECT_NE(msg.find(fragment), std::string::npos) << msg;
  }
}

std::string chainUrdf(int revolute, const char* extra_type = nullptr) {
  std::string x = "<robot name=\"r\"><link name=\"base\"/>";
  for (int i = 1; i <= revolute + (extra_type ? 1 : 0); ++i) x += "<link name=\"l" + std::to_string(i) + "\"/>";
  x += "<link name=\"tool0\"/>";
  std::string prev = "base";
  for (int i = 1; i <= revolute + (extra_type ? 1 : 0); ++i) {
    const std::string type = (extra_type && i == 2) ? extra_type : "revolute";
    x += "<joint name=\"j" + std::to_string(i) + "\" type=\"" + type + "\"><parent link=\"" + prev +
         "\"/><child link=\"l" + std::to_string(i) +
         "\"/><origin xyz=\"0 0 0.1\"/><axis xyz=\"0 0 1\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/></joint>";
    prev = "l" + std::to_string(i);
  }
  x += "<joint name=\"tip\" type=\"fixed\"><parent link=\"" + prev + "\"/><child link=\"tool0\"/></joint></robot>";
  return x;
}

TEST(Kinematics, BadUrdfGivesConfigErrorNamingTheFile) {
  expectConfigError(ftid::test::binaryPath("/does-not-exist.urdf"), "cannot open");
  expectConfigError(writeTemp("kin_test_empty.urdf", ""), "empty");
  expectConfigError(writeTemp("kin_test_garbage.urdf", "<robot name=\"x\"><link name=\"base\"></robot"), "URDF");
  expectConfigError(writeTemp("kin_test_five.urdf", chainUrdf(5)), "expected 6");
  expectConfigError(writeTemp("kin_test_prismatic.urdf", chainUrdf(6, "prismatic")), "not revolute");
  expectConfigError(writeTemp("kin_test_seven.urdf", chainUrdf(7)), "more than 6");
  // A well-formed 6-joint chain loads (the generator above is not what makes the others fail).
  EXPECT_NO_THROW((void)RobotKinematics::fromUrdfFile(writeTemp("kin_test_six.urdf", chainUrdf(6))));
  // Missing tip link.
  try {
    (void)RobotKinematics::fromUrdfFile(urdfPath("ur10.urdf"), "base", "no_such_link");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_link"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("ur10.urdf"), std::string::npos);
  }
}

// Issue 14: a URDF with 60,000 nested elements crashed (SIGSEGV, stack overflow in the XML parser).
// It is now refused by a cheap scan before the parser runs.
TEST(Kinematics, DeeplyNestedUrdfIsRefusedBeforeParsing) {
  std::string deep = "<?xml version=\"1.0\"?>\n<robot name=\"x\">";
  for (int i = 0; i < 60000; ++i) deep += "<a>";
  for (int i = 0; i < 60000; ++i) deep += "</a>";
  deep += "</robot>\n";
  const std::string path = writeTemp("kin_test_deep.urdf", deep);
  try {
    (void)RobotKinematics::fromUrdfFile(path);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find(path + ": XML elements nested 60001 deep"), std::string::npos) << e.what();
  }
  std::remove(path.c_str());
}

TEST(Kinematics, XmlNestingDepthScan) {
  EXPECT_EQ(xmlNestingDepth(""), 0u);
  EXPECT_EQ(xmlNestingDepth("<a/>"), 1u);
  EXPECT_EQ(xmlNestingDepth("<a><b/><c><d x='>' y=\"/>\"></d></c></a>"), 3u);
  EXPECT_EQ(xmlNestingDepth("<?xml version='1.0'?><!-- <x><y><z> --><a><![CDATA[<b><c>]]></a>"), 1u);
  EXPECT_EQ(xmlNestingDepth("<!DOCTYPE r><r><s></s><s><t/></s></r>"), 3u);
  // The shipped URDFs are far below the limit.
  for (const char* name : {"ur10.urdf", "ur10e.urdf"}) {
    std::ifstream in(urdfPath(name));
    std::stringstream ss;
    ss << in.rdbuf();
    EXPECT_LE(xmlNestingDepth(ss.str()), 8u) << name;
    EXPECT_GE(xmlNestingDepth(ss.str()), 3u) << name;
  }
}

TEST(Kinematics, FifoAsUrdfIsRefusedWithoutBlocking) {
  const std::string fifo = ftid::test::binaryPath("/kin_test_fifo.urdf");
  std::remove(fifo.c_str());
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  expectConfigError(fifo, "FIFO");
  std::remove(fifo.c_str());
}

}  // namespace
}  // namespace ftid::model
