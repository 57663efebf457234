// The one robust data treatment (include/ftid/identify/robust_data.hpp): identify leaves the
// glitches out of its fit as `ftid analyze` does (issue 21: the demo's identify warned "up to 6.2x
// the noise floor" where analyze found ~1x). Simulated runs with the simulator's glitches (their
// true positions known) and full Newton-Euler physics.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

#include "ftid/identify/offline.hpp"
#include "ftid/identify/robust_data.hpp"
#include "ftid/logio/log.hpp"
#include "paper_cell.hpp"
#include "test_paths.hpp"

namespace ftid::identify {
namespace {

sim::CellSimConfig glitchyRun(std::uint64_t seed) {
  sim::CellSimConfig cfg = sim::paperCellConfig(test::ur10());
  cfg.seed = seed;
  cfg.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  cfg.glitches.enabled = true;
  cfg.glitches.probability = 0.01;
  cfg.glitches.force_N = 20.0;
  cfg.glitches.torque_Nm = 2.0;
  return cfg;
}

TEST(RobustData, IdentifyLeavesTheGlitchesOutOfItsFit) {
  for (std::uint64_t seed = 5; seed <= 7; ++seed) {
    const sim::CellSimConfig cfg = glitchyRun(seed);
    const sim::CellSim simulator(cfg);
    const std::string path = ftid::test::binaryPath("/robust_data_test_") + std::to_string(seed) + ".csv";
    logio::writeLog(path, simulator.run());
    std::vector<int> truth;
    for (const auto& g : simulator.glitches()) truth.push_back(static_cast<int>(g.sample));
    IdentifyRequest req;
    req.log_path = path;
    req.model = "paper+rigid_body";
    req.robot_urdf = ftid::test::sourcePath("/config/ur10.urdf");
    const CheckedIdentification id = identifyLogFileChecked(req);
    // Every spike is found and nothing else is taken for one (a 20 N spike is 400 sigma).
    EXPECT_EQ(id.glitches, static_cast<int>(truth.size())) << "seed " << seed;
    // The fit saw clean data: the held-out residual is at the noise floor on every axis.
    for (int a = 0; a < 6; ++a) {
      EXPECT_LT(id.check.residual_to_noise(a), 1.15) << "seed " << seed << " axis " << a;
    }
    EXPECT_NEAR(id.set.find("mass")->value, sim::PaperPayload::kMass_kg, 0.01) << "seed " << seed;
    std::remove(path.c_str());
  }
}

TEST(RobustData, FindGlitchesIsTheRuleOnTheResidual) {
  // A white residual with three spikes: exactly those are found.
  std::vector<SampleContext> ctx(400);
  for (std::size_t i = 0; i < ctx.size(); ++i) {
    ctx[i].t = 0.008 * static_cast<double>(i);
    ctx[i].qd.setConstant(0.5);  // moving: a time series
  }
  Eigen::Matrix<double, 6, Eigen::Dynamic> res(6, 400);
  std::uint64_t state = 12345;
  auto gauss = [&]() {  // Box-Muller on a fixed LCG: seeded, deterministic
    auto u = [&]() {
      state = state * 6364136223846793005ULL + 1442695040888963407ULL;
      return (static_cast<double>(state >> 11) + 0.5) / 9007199254740992.0;
    };
    return std::sqrt(-2.0 * std::log(u())) * std::cos(6.283185307179586 * u());
  };
  for (int i = 0; i < 400; ++i) {
    for (int a = 0; a < 6; ++a) res(a, i) = 0.05 * gauss();
  }
  res(0, 50) += 2.0;
  res(4, 200) -= 2.0;
  res(2, 333) += 2.0;
  const Outliers o = findGlitches(ctx, res);
  EXPECT_EQ(o.samples, (std::vector<int>{50, 200, 333}));
  const auto kept = withoutSamples(ctx, o.samples);
  ASSERT_EQ(kept.size(), 397u);
  EXPECT_DOUBLE_EQ(kept[50].t, ctx[51].t);
  EXPECT_DOUBLE_EQ(kept[49].t, ctx[49].t);
}

// keptSeries: column k is input column index[k], the contexts follow, and each segment start maps
// to the first kept sample at or after it (a start inside a left-out run moves to its end).
TEST(RobustData, KeptSeriesSplicesTheKeptSamplesAndMapsTheSegments) {
  const int n = 10;
  Eigen::Matrix<double, 6, Eigen::Dynamic> res(6, n);
  std::vector<SampleContext> ctx(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    res.col(i).setConstant(100.0 + i);
    ctx[static_cast<std::size_t>(i)].t = 0.01 * i;
  }
  //                               0  1  2  3  4  5  6  7  8  9
  const std::vector<char> left_out{1, 0, 0, 1, 1, 0, 0, 0, 1, 0};
  const KeptSeries k = keptSeries(res, ctx, left_out, {0, 4, 8});
  EXPECT_EQ(k.index, (std::vector<int>{1, 2, 5, 6, 7, 9}));
  ASSERT_EQ(k.residual.cols(), 6);
  for (int j = 0; j < 6; ++j) {
    EXPECT_EQ(k.residual(3, j), 100.0 + k.index[static_cast<std::size_t>(j)]);
    EXPECT_EQ(k.ctx[static_cast<std::size_t>(j)].t, 0.01 * k.index[static_cast<std::size_t>(j)]);
  }
  EXPECT_EQ(k.segment_starts, (std::vector<int>{0, 2, 5}));
  // Nothing left out: the input itself; an empty mask means the same.
  const KeptSeries all = keptSeries(res, ctx, {});
  EXPECT_EQ(all.residual, res);
  EXPECT_EQ(all.segment_starts, (std::vector<int>{0}));
}

}  // namespace
}  // namespace ftid::identify
