// `ftid identify`'s physics check of a mass that moves with a signal (include/ftid/identify/
// physical_check.hpp, varyingMass): a dispensing tool whose fitted mass falls with t must still be
// positive at the last sample of the log, or nothing is written.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "ftid/identify/physical_check.hpp"

namespace ftid::identify {
namespace {

ParameterSet dispensingTool() {
  ParameterSet set;
  set.model = "paper+payload(t)";
  set.params = {{"mass", 1.0, 0.001, "kg"}, {"mass_com_z", 0.1, 0.0001, "kg*m"}, {"dmass_t", -0.01, 1e-5, "kg/s"}};
  return set;
}

/// Samples every second from 0 to t_end_s (the model's time, read by the `t` signal).
std::vector<effects::SampleContext> samplesUntil(double t_end_s) {
  std::vector<effects::SampleContext> s(static_cast<std::size_t>(t_end_s) + 1);
  for (std::size_t k = 0; k < s.size(); ++k) s[k].t = s[k].t_model = static_cast<double>(k);
  return s;
}

TEST(VaryingMass, AMassThatRunsOutInsideTheLogIsRefused) {
  const ParameterSet set = dispensingTool();  // 1 kg - 0.01 kg/s: empty at 100 s
  const auto within = varyingMass(set, samplesUntil(80.0));
  ASSERT_TRUE(within.has_value());
  EXPECT_NEAR(within->mass_kg, 0.2, 1e-12);
  EXPECT_EQ(within->t_s, 80.0);
  EXPECT_EQ(within->effects, "payload(t)");
  EXPECT_TRUE(checkPhysicalValidity(set, within).valid);

  const auto beyond = varyingMass(set, samplesUntil(150.0));
  ASSERT_TRUE(beyond.has_value());
  EXPECT_NEAR(beyond->mass_kg, -0.5, 1e-12);
  const PhysicalValidity v = checkPhysicalValidity(set, beyond);
  EXPECT_FALSE(v.valid);
  ASSERT_TRUE(v.problem.has_value());
  EXPECT_EQ(v.problem->key, "parameters.mass");
  EXPECT_NE(v.problem->message.find("payload(t)) is -0.5 kg at t = 150 s"), std::string::npos) << v.problem->message;
  EXPECT_NE(v.line.find("-> REFUSED"), std::string::npos) << v.line;
  EXPECT_NE(physicalRefusal(v).find("no parameter file or export written"), std::string::npos);
  // The constant mass alone (1 kg) passes: the refusal is the signal's doing.
  EXPECT_TRUE(checkPhysicalValidity(set).valid);
}

TEST(VaryingMass, AConstantMassHasNoVaryingPart) {
  ParameterSet set = dispensingTool();
  set.model = "paper";
  set.params.pop_back();
  EXPECT_FALSE(varyingMass(set, samplesUntil(10.0)).has_value());
}

}  // namespace
}  // namespace ftid::identify
