// The simulator's saturation switch (issue 22, `--effect saturation:fz=..`): a reading beyond the
// sensor's range reads the limit; everything inside it is unchanged.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include "ftid/common/error.hpp"
#include "ftid/sim/cell_sim.hpp"
#include "ftid/sim/effect_spec.hpp"
#include "test_paths.hpp"

namespace ftid::sim {
namespace {

TEST(SaturationSwitch, ClipsTheReadingAtTheRange) {
  CellSimConfig c = paperCellConfig(model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/ur10.urdf")));
  c.seed = 3;
  c.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  const logio::LogData clean = CellSim(c).run();
  applyEffectSpec("saturation:fz=8.5,tx=0.3", c);
  EXPECT_EQ(c.saturation.limit(2), 8.5);
  EXPECT_EQ(c.saturation.limit(3), 0.3);
  const logio::LogData clipped = CellSim(c).run();
  ASSERT_EQ(clean.samples.size(), clipped.samples.size());
  int at_limit = 0;
  for (std::size_t k = 0; k < clean.samples.size(); ++k) {
    Wrench expected = clean.samples[k].wrench_S;
    expected(2) = std::clamp(expected(2), -8.5, 8.5);
    expected(3) = std::clamp(expected(3), -0.3, 0.3);
    ASSERT_EQ(clipped.samples[k].wrench_S, expected) << k;
    at_limit += clipped.samples[k].wrench_S(2) == 8.5 ? 1 : 0;
  }
  EXPECT_GT(at_limit, 10);  // the paper cell's fz reaches 9 N
}

TEST(SaturationSwitch, MistakesNameTheKey) {
  CellSimConfig c;
  EXPECT_THROW(applyEffectSpec("saturation:fq=3", c), ConfigError);
  EXPECT_THROW(applyEffectSpec("saturation:fz=-3", c), ConfigError);
  EXPECT_THROW(applyEffectSpec("saturation", c), ConfigError);
}

}  // namespace
}  // namespace ftid::sim
