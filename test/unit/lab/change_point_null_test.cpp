// No false alarms of the change-point scan (include/ftid/lab/change_point.hpp, docs/analyze.md
// "Change points") on clean simulator runs, 50 seeds each: white noise, low-pass filtered noise,
// static pose sets. The laboratory is not told that nothing changed. And the printed standard errors
// of a change point over 20 seeds of a grasp.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <functional>
#include <string>
#include <filesystem>

#include "ftid/lab/analyze.hpp"
#include "ftid/sim/scenarios.hpp"
#include "lab_sim.hpp"

namespace ftid {
namespace {

using labtest::baseConfig;

/// Clean runs of 50 seeds (4 s, the analysis with one cheap candidate: the scan runs against the
/// fitted start whatever the menu, and a smaller menu only makes false alarms likelier): no change
/// point is reported, and the scan's p-value, splits accounted for, is honest: below 0.05 in at
/// most 7 of 50 runs (expected 2.5 for a uniform p; P(X >= 8) = 0.003). At the default alpha a
/// clean run's p is mostly the conservative Bonferroni bound (SimulatedNullGivesCalibratedPValues
/// checks the simulated one).
void expectNoFalseAlarm(const std::function<void(sim::CellSimConfig&)>& setup) {
  int alarms = 0, below_005 = 0;
  for (int k = 0; k < 50; ++k) {
    sim::CellSimConfig c = baseConfig(static_cast<std::uint64_t>(1000 + k));
    c.duration_s = 4.0;
    setup(c);
    const samples::ContextSet set = labtest::contexts(c);
    lab::AnalyzeOptions o;
    o.model = "paper";
    o.candidates = {"time_drift"};
    const auto r = lab::analyze(set.samples, nullptr, o, "sim.csv");
    below_005 += r.change_point_scan_p < 0.05 ? 1 : 0;
    if (!r.change_points.empty()) {
      ++alarms;
      ADD_FAILURE() << "seed " << 1000 + k << ": " << lab::describeChangePoint(r.change_points.front());
    }
  }
  EXPECT_EQ(alarms, 0);
  EXPECT_LE(below_005, 7);
}

TEST(ChangePoint, NoFalseAlarmOnWhiteNoise) {
  expectNoFalseAlarm([](sim::CellSimConfig&) {});
}

TEST(ChangePoint, NoFalseAlarmOnFilteredNoise) {
  expectNoFalseAlarm([](sim::CellSimConfig& c) { c.noise.wrench_lowpass_hz = 8.0; });
}

TEST(ChangePoint, NoFalseAlarmOnStaticPoseSets) {
  expectNoFalseAlarm([](sim::CellSimConfig& c) {
    c.static_poses.enabled = true;
    c.static_poses.poses = 30;
    c.static_poses.hold_s = 0.2;
  });
}

/// A smooth effect whose fit the rule refuses is still no change in time. With the sensor's
/// crosstalk at half the simulator's matrix and full rigid-body physics (`ftid simulate --seed N
/// --effect crosstalk:scale=0.5`, the paper's cell, 10 s), the starting model `paper` misses both;
/// from it crosstalk is refused (its gains are confounded with the payload) and rigid_body too (its
/// inertia comes out non-physical), yet they lower the held-out error by 13-18 %. The scan's best
/// split gains less, and while only the recommended candidates were its competition it was
/// reported as "three set-ups" in 5 of these 24 seeds (3, 7, 15, 20, 21: offsets steps of 0.1 N
/// and back, or a payload change of -0.014 kg for 1.5 s). A step must beat every candidate whose
/// held-out gain the rule finds significant. Through the log file, as the commands do.
TEST(ChangePoint, NoStepWhereASmoothEffectsFitIsRefused) {
  const std::string dir = ::testing::TempDir() + "cp_refused_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  for (std::uint64_t seed = 1; seed <= 24; ++seed) {
    const auto r = labtest::analyzeCommandLineRun(dir + "/crosstalk_" + std::to_string(seed) + ".csv", seed,
                                                  "crosstalk:scale=0.5", false);
    for (const auto& cp : r.change_points) ADD_FAILURE() << "seed " << seed << ": " << lab::describeChangePoint(cp);
    bool competitor = false;  // the case is the one described: a refused smooth effect beats the split
    for (const auto& cand : r.candidates) competitor = competitor || cand.verdict == lab::Verdict::kRefused;
    EXPECT_TRUE(competitor) << "seed " << seed;
  }
  if (!HasFailure()) std::filesystem::remove_all(dir);
}

/// The scan's p-value with its simulated null (alpha 0.5 makes every scan simulate it; at the
/// default alpha a clean run reports the Bonferroni bound instead): over 50 white-noise seeds,
/// below 0.05 in at most 7 (expected 2.5) and below 0.5 in at least 10 (expected 25; an honest p is
/// not stuck at 1).
TEST(ChangePoint, SimulatedNullGivesCalibratedPValues) {
  int below_005 = 0, below_05 = 0;
  for (int k = 0; k < 50; ++k) {
    sim::CellSimConfig c = baseConfig(static_cast<std::uint64_t>(3000 + k));
    c.duration_s = 4.0;
    const samples::ContextSet set = labtest::contexts(c);
    lab::AnalyzeOptions o;
    o.model = "paper";
    o.candidates = {"time_drift"};
    o.family_alpha = 0.5;
    const auto r = lab::analyze(set.samples, nullptr, o, "sim.csv");
    below_005 += r.change_point_scan_p < 0.05 ? 1 : 0;
    below_05 += r.change_point_scan_p < 0.5 ? 1 : 0;
  }
  RecordProperty("below_005", below_005);
  RecordProperty("below_05", below_05);
  EXPECT_LE(below_005, 7);
  EXPECT_GE(below_05, 10);
}

/// The printed standard errors are claims: over 20 seeds of a grasp (0.5 kg at 2.0 s, 4 s runs),
/// the mass step's error in units of its printed standard error has an RMS between 0.6 and 1.6
/// (20 draws of a unit normal: 0.7-1.3 at 99 %; the margin is the split's own error), and the time
/// lies within three of its printed standard deviations plus one sample in at least 18 of 20.
TEST(ChangePoint, PrintedUncertaintiesHoldOverSeeds) {
  double sum_z2 = 0.0;
  int t_inside = 0;
  const int seeds = 20;
  for (int k = 0; k < seeds; ++k) {
    sim::CellSimConfig c = baseConfig(static_cast<std::uint64_t>(2000 + k));
    c.duration_s = 4.0;
    c.payload_change.enabled = true;
    c.payload_change.t_s = 2.0;
    c.payload_change.added = sim::compactObject(0.5, Vec3(0.02, 0.01, 0.08));
    const samples::ContextSet set = labtest::contexts(c);
    lab::AnalyzeOptions o;
    o.model = "paper";
    o.candidates = {"time_drift"};
    const auto r = lab::analyze(set.samples, nullptr, o, "sim.csv");
    ASSERT_EQ(r.change_points.size(), 1u) << "seed " << 2000 + k;
    const auto& cp = r.change_points.front();
    for (const auto& d : cp.delta) {
      if (d.name == "mass") sum_z2 += std::pow((d.value - 0.5) / d.std, 2);
    }
    t_inside += std::abs(cp.t - 2.0) <= 3.0 * cp.t_std + 1.0 / c.rate_hz ? 1 : 0;
  }
  const double rms_z = std::sqrt(sum_z2 / seeds);
  RecordProperty("mass_rms_z", std::to_string(rms_z));
  RecordProperty("t_inside", t_inside);
  EXPECT_GT(rms_z, 0.6);
  EXPECT_LT(rms_z, 1.6);
  EXPECT_GE(t_inside, 18);
}

/// A sensor re-bias that stays (the log's wrench shifted from 2.0 s on), 20 seeds of 4 s runs: one
/// change point every time, never a second (the second change's test, src/lab/change_point_scan.cpp,
/// on data with exactly one change).
TEST(ChangePoint, ARebiasThatStaysIsOneChangeOverSeeds) {
  Wrench bias;
  bias << 0.4, -0.3, 0.5, 0.03, -0.02, 0.04;
  for (int k = 0; k < 20; ++k) {
    sim::CellSimConfig c = baseConfig(static_cast<std::uint64_t>(4000 + k));
    c.duration_s = 4.0;
    logio::LogData log = sim::CellSim(c).run();
    for (auto& s : log.samples) {
      if (s.t >= 2.0) s.wrench_S += bias;
    }
    const samples::ContextSet set = samples::buildContexts(log, *c.robot, {c.R_FS, c.p_FS_F, 0.0, 0.0});
    lab::AnalyzeOptions o;
    o.model = "paper";
    o.candidates = {"time_drift"};
    const auto r = lab::analyze(set.samples, nullptr, o, "sim.csv");
    ASSERT_FALSE(r.change_points.empty()) << "seed " << 4000 + k;
    EXPECT_EQ(r.change_points.size(), 1u) << "seed " << 4000 + k << ": " << lab::describeChangePoint(r.change_points.back());
    EXPECT_EQ(r.change_points.front().kind, "offsets");
  }
}

}  // namespace
}  // namespace ftid
