// Change points in time (include/ftid/lab/change_point.hpp, docs/analyze.md "Change points") on
// simulator runs the laboratory is not told about: an object grasped mid-run (the simulator's second
// rigid body, its own Newton-Euler), a sensor re-bias (the log's wrench columns shifted after t),
// and clean runs (white, filtered noise, static pose sets) that must report none.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "ftid/lab/analyze.hpp"
#include "ftid/sim/scenarios.hpp"
#include "lab_sim.hpp"

namespace ftid {
namespace {

using labtest::baseConfig;

/// The laboratory on a run, with one cheap candidate (the scan runs against the fitted start model
/// whatever the menu; a smaller menu makes the family smaller, i.e. false alarms likelier).
lab::AnalysisResult analyzeLog(const logio::LogData& log, const sim::CellSimConfig& c, const std::string& model) {
  const samples::ContextSet set = samples::buildContexts(log, *c.robot, {c.R_FS, c.p_FS_F, 0.0, 0.0});
  lab::AnalyzeOptions o;
  o.model = model;
  o.candidates = {"time_drift"};
  return lab::analyze(set.samples, nullptr, o, "sim.csv");
}

lab::AnalysisResult analyzeRun(const sim::CellSimConfig& c, const std::string& model = "paper") {
  return analyzeLog(sim::CellSim(c).run(), c, model);
}

const lab::ChangeDelta* deltaOf(const lab::ChangePoint& cp, const std::string& name) {
  for (const auto& d : cp.delta) {
    if (d.name == name) return &d;
  }
  return nullptr;
}

sim::CellSimConfig graspRun(std::uint64_t seed, double t_s, double mass) {
  sim::CellSimConfig c = baseConfig(seed);
  c.payload_change.enabled = true;
  c.payload_change.t_s = t_s;
  c.payload_change.added = sim::compactObject(mass, Vec3(0.01, -0.02, 0.10));
  return c;
}

TEST(ChangePoint, GraspFoundWithTimeAndMass) {
  struct Case {
    std::uint64_t seed;
    double t_s, mass;
  };
  for (const Case& k : {Case{1, 5.0, 0.6}, Case{2, 3.3, 0.6}, Case{3, 7.1, 0.4}}) {
    const auto r = analyzeRun(graspRun(k.seed, k.t_s, k.mass));
    ASSERT_EQ(r.change_points.size(), 1u) << "seed " << k.seed;
    const auto& cp = r.change_points.front();
    EXPECT_EQ(cp.kind, "payload");
    EXPECT_NEAR(cp.t, k.t_s, 0.2) << "seed " << k.seed;
    const auto* dm = deltaOf(cp, "mass");
    ASSERT_NE(dm, nullptr);
    EXPECT_NEAR(dm->value, k.mass, 0.1 * k.mass) << "seed " << k.seed;
    std::printf("seed %d t %.4f +- %.4f  mass %.4f +- %.4f\n", static_cast<int>(k.seed), cp.t, cp.t_std, dm->value, dm->std);
  }
}

}  // namespace
}  // namespace ftid
