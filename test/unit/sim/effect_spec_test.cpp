// `ftid simulate --effect NAME[:key=value,...]` (sim/effect_spec.hpp): each effect and key lands in
// the simulator's configuration; mistakes are ConfigErrors naming the effect and the key.
#include "ftid/sim/effect_spec.hpp"

#include <gtest/gtest.h>

#include <string>

#include "ftid/common/error.hpp"

namespace ftid::sim {
namespace {

std::string errorOf(const std::string& spec) {
  CellSimConfig c;
  try {
    applyEffectSpec(spec, c);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(EffectSpec, KeysLandInTheConfiguration) {
  CellSimConfig c;
  applyEffectSpec("cable:k=5,anchor=-0.7/-0.3/1.4,attach=0;0;0.1", c);
  EXPECT_TRUE(c.cable.enabled);
  EXPECT_EQ(c.cable.stiffness_N_per_m, 5.0);
  EXPECT_EQ(c.cable.p_BA_B, Vec3(-0.7, -0.3, 1.4));
  EXPECT_EQ(c.cable.p_SA_S, Vec3(0.0, 0.0, 0.1));
  applyEffectSpec("sensor_delay:tau=-0.008", c);
  EXPECT_TRUE(c.sensor_delay.enabled);
  EXPECT_EQ(c.sensor_delay.tau_s, -0.008);
  applyEffectSpec("mounting:yaw=90", c);
  EXPECT_TRUE(c.mounting.enabled);
  EXPECT_DOUBLE_EQ(c.mounting.rpy_rad.z(), 3.141592653589793 / 2.0);
  applyEffectSpec("contact:start=1,end=2,force=0/0/-10,point=0/0/0.2", c);
  EXPECT_EQ(c.contact.t_end_s, 2.0);
  EXPECT_EQ(c.contact.force_B, Vec3(0.0, 0.0, -10.0));
  const Mat6 before = c.crosstalk.E;
  ASSERT_GT(before.norm(), 0.0);
  applyEffectSpec("crosstalk:scale=2", c);
  EXPECT_TRUE(c.crosstalk.E.isApprox(2.0 * before, 0.0));
  c.full_rigid_body = false;
  applyEffectSpec("rigid_body", c);
  EXPECT_TRUE(c.full_rigid_body);
  applyEffectSpec("temperature_drift", c);  // defaults
  EXPECT_TRUE(c.temperature_drift.enabled);
  applyEffectSpec("grasp:t=4,mass=0.5", c);
  EXPECT_FALSE(c.payload_change.released);
  EXPECT_TRUE(c.payload_change.holds(4.0));
  EXPECT_FALSE(c.payload_change.holds(3.99));
  applyEffectSpec("release:t=4,mass=0.5", c);
  EXPECT_TRUE(c.payload_change.released);
  EXPECT_EQ(c.payload_change.added.mass_kg, 0.5);
  EXPECT_TRUE(c.payload_change.holds(3.99));
  EXPECT_FALSE(c.payload_change.holds(4.0));
}

TEST(EffectSpec, MistakesNameTheEffectAndTheKey) {
  EXPECT_NE(errorOf("cable:k=5N").find("--effect cable k: not a finite number: '5N'"), std::string::npos);
  EXPECT_NE(errorOf("cable:anchor=1/2").find("--effect cable anchor: expected 3 values"), std::string::npos);
  EXPECT_NE(errorOf("cable:anchor=1/2/3/").find("--effect cable anchor"), std::string::npos);
  EXPECT_NE(errorOf("cable:stiffness=5").find("unknown key 'stiffness'"), std::string::npos);
  EXPECT_NE(errorOf("cable:k").find("expected key=value"), std::string::npos);
  EXPECT_NE(errorOf("glitches:p=nan").find("--effect glitches p"), std::string::npos);
  EXPECT_NE(errorOf("rigid_body:x=1").find("unknown key 'x'"), std::string::npos);
  EXPECT_NE(errorOf("release:mass=-1").find("--effect release"), std::string::npos);
  EXPECT_NE(errorOf("wind").find("unknown effect 'wind'"), std::string::npos);
}

}  // namespace
}  // namespace ftid::sim
