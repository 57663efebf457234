// Saturation and clipping (include/ftid/identify/saturation.hpp, issue 22): a sensor whose fz is
// clipped at the top of its range on ~3 % of samples. The run is the cell simulator's (its own
// physics); the clip is applied to the logged wrench afterwards, as the sensor's electronics
// would. The detector alone here; on clean logs (no false alarms) in saturation_stats_test.cpp;
// identify and analyze on a clipped run (the payload unbiased) in test/unit/lab/saturation_test.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "ftid/common/error.hpp"
#include "ftid/identify/robust_data.hpp"
#include "ftid/identify/saturation.hpp"
#include "paper_cell.hpp"
#include "saturation_sim.hpp"

namespace ftid::identify {
namespace {

TEST(Saturation, FlatTopPValueIsTheBinomialTail) {
  EXPECT_DOUBLE_EQ(flatTopPValue(1, 1), 0.75);           // P(X >= 1), X ~ Bin(2, 1/2)
  EXPECT_DOUBLE_EQ(flatTopPValue(10, 0), std::pow(2.0, -10));
  EXPECT_NEAR(flatTopPValue(3, 3), 42.0 / 64.0, 1e-12);  // (20 + 15 + 6 + 1) / 64
  EXPECT_DOUBLE_EQ(flatTopPValue(0, 5), 1.0);
  EXPECT_LT(flatTopPValue(150, 2), 1e-40);  // counts in the thousands stay finite
  EXPECT_GT(flatTopPValue(2000, 2000), 0.49);
}

TEST(Saturation, RatedRangeSyntax) {
  const Vec6 r = parseRatedRange("fz=120,tx=10.5");
  EXPECT_EQ(r(2), 120.0);
  EXPECT_EQ(r(3), 10.5);
  EXPECT_EQ(r(0), 0.0);
  EXPECT_THROW(parseRatedRange("fq=1"), ConfigError);
  EXPECT_THROW(parseRatedRange("fz=-3"), ConfigError);
  EXPECT_THROW(parseRatedRange("fz=12N"), ConfigError);
  EXPECT_THROW(parseRatedRange("fz"), ConfigError);
}

TEST(Saturation, ACLippedAxisIsCountedExactly) {
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    logio::LogData log = sim::CellSim(test::paperConfig(true, seed)).run();
    const satsim::Clip clip = satsim::clipAxis(log, 2, 0.03);
    const Saturation s = findSaturation(satsim::readings(log));
    ASSERT_EQ(s.axes.size(), 1U) << "seed " << seed;
    EXPECT_EQ(s.axes[0].axis, 2);
    EXPECT_EQ(s.axes[0].side, 1);
    EXPECT_TRUE(s.axes[0].flat_top);
    EXPECT_EQ(s.axes[0].value, clip.limit);
    EXPECT_EQ(s.axes[0].count, clip.count) << "seed " << seed;
    EXPECT_EQ(static_cast<int>(s.samples.size()), clip.count);
    EXPECT_EQ(static_cast<int>(s.axes[0].times.size()), kMaxSaturationTimes);
    EXPECT_EQ(s.axes[0].times.front(), log.samples[static_cast<std::size_t>(s.samples.front())].t);
  }
}

TEST(Saturation, ARatedRangeMarksTheSamplesBeyondIt) {
  logio::LogData log = sim::CellSim(test::paperConfig(true, 4)).run();
  std::vector<SampleContext> ctx = satsim::readings(log);
  std::vector<double> tz;
  for (const auto& c : ctx) tz.push_back(c.wrench_S(5));
  std::sort(tz.begin(), tz.end());
  const double limit = -tz[tz.size() / 50];  // the lowest 2 % of tz reach -limit
  int beyond = 0;
  for (const auto& c : ctx) beyond += std::abs(c.wrench_S(5)) >= limit ? 1 : 0;
  SaturationOptions o;
  o.rated_range(5) = limit;
  const Saturation s = findSaturation(ctx, o);
  ASSERT_FALSE(s.axes.empty());
  int counted = 0;
  for (const auto& a : s.axes) {
    EXPECT_EQ(a.axis, 5);
    EXPECT_TRUE(a.rated);
    EXPECT_FALSE(a.flat_top);  // not clipped: only the rated range says so
    counted += a.count;
  }
  EXPECT_EQ(counted, beyond);
}

TEST(Saturation, RepeatedReadingsAreNoFlatTop) {
  // A noise-free static pose set: every hold reads one value on all six axes (the pose with the
  // largest fz too), and a sensor read twice as fast as it updates (each reading logged 3 times).
  // A repeated reading counts once: neither is taken for a clip.
  sim::CellSimConfig cfg = test::paperConfig(false, 1);
  cfg.static_poses.enabled = true;
  cfg.static_poses.poses = 30;
  cfg.static_poses.hold_s = 0.2;
  EXPECT_TRUE(findSaturation(satsim::readings(sim::CellSim(cfg).run())).axes.empty());
  logio::LogData log = sim::CellSim(test::paperConfig(true, 2)).run();
  for (std::size_t i = 0; i < log.samples.size(); ++i) log.samples[i].wrench_S = log.samples[i - i % 3].wrench_S;
  EXPECT_TRUE(findSaturation(satsim::readings(log)).axes.empty());
  // ... but a clipped axis among changing ones is one, repeated or not (10 %: a third of the
  // readings are fresh, and a flat top needs about 17 fresh readings to be called).
  const satsim::Clip clip = satsim::clipAxis(log, 2, 0.10, 1e-3);
  const Saturation s = findSaturation(satsim::readings(log));
  ASSERT_EQ(s.axes.size(), 1U);
  EXPECT_EQ(s.axes[0].count, clip.count);
}

TEST(Saturation, AHoldAtTheExtremeIsNoFlatTopButAClipIs) {
  // fz = 10 sin(t) + noise, all axes noisy, except a hold of 0.5 s at fz's peak: noise-free (the
  // six readings repeat: a held reading, counted once) or with the other axes still changing (fz
  // alone flat at its extreme: a clip).
  for (const bool others_change : {false, true}) {
    std::vector<SampleContext> ctx(2000);
    std::mt19937_64 rng(7);
    std::normal_distribution<double> noise(0.0, 0.05);
    for (std::size_t i = 0; i < ctx.size(); ++i) {
      ctx[i].t = 0.01 * static_cast<double>(i);
      for (int a = 0; a < 6; ++a) ctx[i].wrench_S(a) = noise(rng);
      ctx[i].wrench_S(2) += 10.0 * std::sin(ctx[i].t);
    }
    const std::size_t peak = 157;  // t = pi / 2
    for (std::size_t i = peak; i < peak + 50; ++i) {
      if (others_change) {
        ctx[i].wrench_S(2) = 10.2;
      } else {
        ctx[i].wrench_S = Wrench::Constant(0.01);
        ctx[i].wrench_S(2) = 10.2;
      }
    }
    const Saturation s = findSaturation(ctx);
    if (others_change) {
      ASSERT_EQ(s.axes.size(), 1U);
      EXPECT_EQ(s.axes[0].count, 50);
    } else {
      EXPECT_TRUE(s.axes.empty());
    }
  }
}

TEST(Saturation, LeaveOutBadSamplesMapsTheGlitchesBack) {
  EXPECT_EQ(originalIndices({2, 3}, {0, 1, 2, 5}), (std::vector<int>{0, 1, 4, 7}));
  EXPECT_EQ(originalIndices({}, {0, 3}), (std::vector<int>{0, 3}));
  EXPECT_EQ(originalIndices({0}, {0}), (std::vector<int>{1}));
}

}  // namespace
}  // namespace ftid::identify
