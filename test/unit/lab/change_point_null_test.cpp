// No false alarms of the change-point scan (include/ftid/lab/change_point.hpp, docs/analyze.md
// "Change points") on clean simulator runs, 50 seeds each: white noise, low-pass filtered noise,
// static pose sets. The laboratory is not told that nothing changed.
#include <gtest/gtest.h>

#include <functional>

#include "ftid/lab/analyze.hpp"
#include "lab_sim.hpp"

namespace ftid {
namespace {

using labtest::baseConfig;

/// Clean runs of 50 seeds (4 s, the analysis with one cheap candidate: the scan runs against the
/// fitted start whatever the menu, and a smaller menu only makes false alarms likelier): no change
/// point is reported, and the scan's p-value, splits accounted for, is honest: below 0.05 in at
/// most 7 of 50 runs (expected 2.5; P(X >= 8) = 0.003 for a uniform p) and below 0.5 in at most 35
/// (a p-value piled up near 0 fails the first, one stuck near 1 is allowed: it is conservative).
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

}  // namespace
}  // namespace ftid
