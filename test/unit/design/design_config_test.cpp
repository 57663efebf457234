// config/design.yaml (loadDesignConstraints): the shipped file merges with the URDF; a bad value's
// error names the file, line, column and key; unknown keys are errors.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "ftid/common/error.hpp"
#include "ftid/design/designer.hpp"
#include "ftid/model/kinematics.hpp"
#include "test_paths.hpp"

namespace ftid::design {
namespace {

const model::RobotKinematics& ur10() {
  static const model::RobotKinematics k =
      model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/ur10.urdf"));
  return k;
}

class DesignConfigFile : public ::testing::Test {
 protected:
  void TearDown() override { std::remove(path_.c_str()); }
  std::string write(const std::string& text) {
    std::ofstream(path_) << text;
    return path_;
  }
  std::string errorOf(const std::string& text) {
    try {
      (void)loadDesignConstraints(write(text), ur10(), JointVector::Zero());
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "(no error)";
  }
  std::string path_ = ftid::test::binaryPath("/design_config_test_") + std::to_string(::getpid()) + ".yaml";
};

TEST_F(DesignConfigFile, ShippedFileEqualsTheBuiltInDefaults) {
  const JointVector q0 = JointVector::Zero();
  const auto shipped = loadDesignConstraints(ftid::test::sourcePath("/config/design.yaml"), ur10(), q0);
  const auto builtin = loadDesignConstraints("", ur10(), q0);
  EXPECT_EQ(shipped.velocity, builtin.velocity);
  EXPECT_EQ(shipped.acceleration, builtin.acceleration);
  EXPECT_EQ(shipped.position_lower, builtin.position_lower);
  EXPECT_EQ(shipped.position_upper, builtin.position_upper);
  EXPECT_EQ(shipped.keep_out.size(), builtin.keep_out.size());
  EXPECT_EQ(shipped.tool.size(), builtin.tool.size());
}

TEST_F(DesignConfigFile, ReadsValuesTighterWins) {
  const auto c = loadDesignConstraints(write("limits:\n  velocity: [0.5, 9, 9, 9, 9, 9]\n"
                                             "workspace:\n  floor_z: -0.25\n  keep_out:\n  tool:\n"
                                             "    - {center: [0, 0, 0.1], radius: 0.05}\n"),
                                       ur10(), JointVector::Zero());
  EXPECT_EQ(c.velocity[0], 0.5);
  EXPECT_LE(c.velocity[1], 9.0);
  EXPECT_EQ(c.floor_z_B, -0.25);
  EXPECT_TRUE(c.keep_out.empty());  // an empty keep_out clears the defaults
  ASSERT_EQ(c.tool.size(), 1u);
  EXPECT_EQ(c.tool[0].radius, 0.05);
}

TEST_F(DesignConfigFile, BadValuesNameFileLineColumnAndKey) {
  std::string m = errorOf("limits:\n  velocity: [1, 1, 1, 1, 1, x]\n");
  EXPECT_NE(m.find(path_ + ":2:29: key 'limits.velocity[5]': expected a number, got 'x'"), std::string::npos) << m;
  m = errorOf("workspace:\n  keep_out:\n    - {name: a, center: [0, 0, 0], radius: -1}\n");
  EXPECT_NE(m.find(path_ + ":3:44: key 'workspace.keep_out[0].radius': must not be negative"), std::string::npos) << m;
  m = errorOf("workspace:\n  tool:\n    - {radius: 1}\n");
  EXPECT_NE(m.find(path_ + ":3:7: key 'workspace.tool[0].center': missing"), std::string::npos) << m;
  m = errorOf("limits:\n  velocty: [1, 1, 1, 1, 1, 1]\n");
  EXPECT_NE(m.find(path_ + ":2:3: key 'limits.velocty': unknown key"), std::string::npos) << m;
  m = errorOf("sensor_mount:\n  xyz: [0, 0, .inf]\n");
  EXPECT_NE(m.find(path_ + ":2:15: key 'sensor_mount.xyz[2]': must be finite"), std::string::npos) << m;
}

}  // namespace
}  // namespace ftid::design
