// Exports of an identified payload: UR set_target_payload and ros2_control GravityCompensation.
#include <gtest/gtest.h>

#include <cmath>

#include "ftid/cell/exports.hpp"

namespace {

ftid::identify::ParameterSet makeSet() {
  ftid::identify::ParameterSet set;
  set.model = "paper";
  set.params = {{"mass", 0.9, 0.001, "kg"}, {"f0_x", -0.5, 0.01, "N"}, {"t0_z", 0.02, 0.001, "Nm"}};
  set.derived = {{"com_x", 0.01, 1e-4, "m"}, {"com_y", 0.0, 1e-4, "m"}, {"com_z", 0.02, 1e-4, "m"}};
  set.tilt_estimated = true;
  set.tilt_u_rad = 0.1;
  set.tilt_v_rad = -0.05;
  return set;
}

TEST(PayloadExport, CentreOfGravityIsExpressedInTheFlangeFrame) {
  // Sensor rotated +90 deg about the flange z axis and 5 cm out along it.
  ftid::Mat3 R_FS;
  R_FS << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  const ftid::Vec3 p_FS_F(0, 0, 0.05);
  const auto e = ftid::cell::makePayloadExport(makeSet(), R_FS, p_FS_F);
  // x_S = (1,0,0) is y_F, so com_S = (0.01, 0, 0.02) is (0, 0.01, 0.02) in F, plus the mount offset.
  EXPECT_NEAR(e.cog_F.x(), 0.0, 1e-15);
  EXPECT_NEAR(e.cog_F.y(), 0.01, 1e-15);
  EXPECT_NEAR(e.cog_F.z(), 0.07, 1e-15);
  EXPECT_DOUBLE_EQ(e.mass, 0.9);
  EXPECT_FALSE(e.inertia_C_F.has_value());
  EXPECT_DOUBLE_EQ(e.f0_S.x(), -0.5);
}

TEST(PayloadExport, GravityFieldCarriesTheTilt) {
  const auto e = ftid::cell::makePayloadExport(makeSet(), ftid::Mat3::Identity(), ftid::Vec3::Zero());
  // Paper Eq. 13 written out: g_B = g (cos U sin V, -sin U, -cos U cos V).
  const double g = 9.80665, u = 0.1, v = -0.05;
  EXPECT_NEAR(e.gravity_B.x(), g * std::cos(u) * std::sin(v), 1e-12);
  EXPECT_NEAR(e.gravity_B.y(), -g * std::sin(u), 1e-12);
  EXPECT_NEAR(e.gravity_B.z(), -g * std::cos(u) * std::cos(v), 1e-12);
  const std::string yaml = ftid::cell::ros2GravityCompensationYaml(e);
  EXPECT_NE(yaml.find("mass: 0.9\n"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("pos: [0.01, 0, 0.02]"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("gravity_field: ["), std::string::npos) << yaml;
}

TEST(PayloadExport, InertiaIsRotatedIntoTheFlangeFrameInUrOrder) {
  auto set = makeSet();
  // I_C in S: diag(1, 2, 3) e-3 with an xy product 0.5e-3.
  set.derived.push_back({"i_c_xx", 1e-3, 0, ""});
  set.derived.push_back({"i_c_yy", 2e-3, 0, ""});
  set.derived.push_back({"i_c_zz", 3e-3, 0, ""});
  set.derived.push_back({"i_c_xy", 0.5e-3, 0, ""});
  set.derived.push_back({"i_c_xz", 0.0, 0, ""});
  set.derived.push_back({"i_c_yz", 0.0, 0, ""});
  ftid::Mat3 R_FS;
  R_FS << 0, -1, 0, 1, 0, 0, 0, 0, 1;  // +90 deg about z: x_S -> y_F, y_S -> -x_F
  const auto e = ftid::cell::makePayloadExport(set, R_FS, ftid::Vec3::Zero());
  ASSERT_TRUE(e.inertia_C_F.has_value());
  const ftid::Mat3& I = *e.inertia_C_F;
  // Moments swap between x and y, the product changes sign.
  EXPECT_NEAR(I(0, 0), 2e-3, 1e-15);
  EXPECT_NEAR(I(1, 1), 1e-3, 1e-15);
  EXPECT_NEAR(I(2, 2), 3e-3, 1e-15);
  EXPECT_NEAR(I(0, 1), -0.5e-3, 1e-15);
  const std::string line = ftid::cell::urScriptPayload(e);
  EXPECT_EQ(line, "set_target_payload(0.9, [0, 0.01, 0.02], [0.002, 0.001, 0.003, -0.0005, 0, 0])");
}

TEST(PayloadExport, MissingMassIsAClearError) {
  ftid::identify::ParameterSet set;
  set.model = "offsets";
  try {
    ftid::cell::makePayloadExport(set, ftid::Mat3::Identity(), ftid::Vec3::Zero());
    FAIL() << "expected ConfigError";
  } catch (const std::exception& ex) {
    EXPECT_NE(std::string(ex.what()).find("'mass'"), std::string::npos) << ex.what();
  }
}

}  // namespace
