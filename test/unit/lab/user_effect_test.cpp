// The user's own effect, expr(axes: expression) (docs/effects.md), ranked by the laboratory like
// any other: a disturbance written into a simulated run directly from its log columns (not through
// ftid's regressor) is found, recommended and fitted; on the same run without it, it is not.
#include <gtest/gtest.h>

#include <cmath>

#include "lab_sim.hpp"

namespace ftid {
namespace {

constexpr double kGain = 2.0;  // [N s/rad]: fz += kGain * grip * qd6 (e.g. a fan on the gripper)
const char* const kEffect = "expr(fz: grip*qd6)";

/// A 10 s simulated run with a logged gripper signal `grip` (0..1, 0.13 Hz); with `disturbed`,
/// fz also carries kGain * grip * qd6.
samples::ContextSet runWithGrip(std::uint64_t seed, bool disturbed) {
  const sim::CellSimConfig c = labtest::baseConfig(seed);
  logio::LogData log = sim::CellSim(c).run();
  std::vector<double> grip(log.samples.size());
  for (std::size_t i = 0; i < log.samples.size(); ++i) {
    auto& s = log.samples[i];
    grip[i] = 0.5 + 0.5 * std::sin(2.0 * M_PI * 0.13 * s.t);
    if (disturbed) s.wrench_S(2) += kGain * grip[i] * s.qd(5);
  }
  log.extra_names.push_back("grip");
  log.extra_columns.push_back(grip);
  return samples::buildContexts(log, *c.robot, {c.R_FS, c.p_FS_F, 0.0, 0.0});
}

lab::AnalysisResult rank(const samples::ContextSet& set, const std::string& model) {
  lab::AnalyzeOptions o;
  o.model = model;
  o.candidates = {kEffect, "time_drift", "harmonic(q6,1)", "poly(grip,1)"};
  return lab::analyze(set.samples, nullptr, o, "sim.csv");
}

TEST(UserEffect, TheLaboratoryRanksItFirstAndFitsItsCoefficient) {
  const samples::ContextSet set = runWithGrip(11, true);
  const lab::AnalysisResult r = rank(set, "paper");
  ASSERT_FALSE(r.candidates.empty());
  EXPECT_EQ(r.candidates.front().effect, kEffect);
  EXPECT_TRUE(r.candidates.front().significant) << r.candidates.front().reason;
  EXPECT_GT(r.candidates.front().relative_reduction, 0.9);

  const lab::AnalysisResult with = rank(set, std::string("paper+") + kEffect);
  const lab::ParamEstimate* gain = labtest::findParam(with.report, "expr_fz_grip_times_qd6");
  ASSERT_NE(gain, nullptr);
  EXPECT_GT(gain->std, 0.0);
  EXPECT_LT(std::abs(gain->value - kGain), 4.0 * gain->std) << gain->value << " +- " << gain->std;
  EXPECT_LT(with.report.residual_rms(2), 1.2 * with.noise_floor(2))
      << with.report.residual_rms(2) << " vs noise " << with.noise_floor(2);
  for (const auto& c : with.candidates) EXPECT_FALSE(c.significant) << c.effect;
}

TEST(UserEffect, NotRecommendedWhereTheDataHasNoSuchEffect) {
  const lab::AnalysisResult r = rank(runWithGrip(12, false), "paper");
  for (const auto& c : r.candidates) {
    EXPECT_FALSE(c.significant) << c.effect << " family p " << c.family_p;
  }
}

}  // namespace
}  // namespace ftid
