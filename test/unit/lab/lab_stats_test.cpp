// Statistical claims of `ftid analyze` tested as claims (issue 11):
//  - the parameters' reported standard errors match their scatter over many noise seeds (+-30 %),
//    and the check rejects standard errors 1.7x off (../identify/seed_study.hpp);
//  - each false-alarm guard of the candidate ranking (Bonferroni over the candidates, and the
//    held-out condition) is measured on its own, on a data set that needs it;
//  - ranking is by held-out, not in-sample, improvement: an overfitting candidate that gains most
//    in-sample ranks below the effect that is really there.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <cstdio>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "../identify/seed_study.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/lab/analyze.hpp"
#include "lab_sim.hpp"

namespace ftid::lab {
namespace {

using stats_test::Estimates;

// --- Standard errors of the laboratory's parameters ----------------------------------------------

double truthOf(const sim::CellSimConfig& c, const std::string& name) {
  const char* ax = "xyz";
  for (int i = 0; i < 3; ++i) {
    if (name == std::string("com_") + ax[i]) return c.payload.p_SC_S(i);
    if (name == std::string("f0_") + ax[i]) return c.F0_N(i);
    if (name == std::string("t0_") + ax[i]) return c.T0_Nm(i);
  }
  if (name == "mass") return c.payload.mass_kg;
  if (name == "tilt_u") return c.tilt_u_rad;
  if (name == "tilt_v") return c.tilt_v_rad;
  throw std::out_of_range(name);
}

TEST(LabStats, ParameterSpreadOverSeedsMatchesReportedStandardErrors) {
  const sim::CellSimConfig noisy = labtest::baseConfig(1);
  sim::CellSimConfig clean = noisy;
  clean.noise = sim::NoiseConfig{};
  const std::vector<SampleContext> ctx = labtest::contexts(clean).samples;
  AnalyzeOptions o;
  o.model = "paper";
  o.candidates = {"poly(t,1)"};  // the ranking is not under test here: one cheap candidate
  const stats_test::Estimator analyzeParams = [&o](const std::vector<SampleContext>& c) {
    const AnalysisResult r = analyze(c, nullptr, o, "sim.csv");
    Estimates e;
    for (const auto& p : r.report.params) e[p.name] = {p.value, p.std};
    return e;
  };
  const auto study = stats_test::runSeedStudy(ctx, stats_test::simulatorWhiteNoise(noisy), analyzeParams, 300, 7000);
  for (const char* name : {"mass", "com_z", "com_y", "f0_x", "t0_y", "tilt_u", "tilt_v"}) {
    stats_test::expectClaim(study, name, truthOf(noisy, name));
  }
}


// --- False-alarm guards, each on its own -----------------------------------------------------------

int testedCandidates(const AnalysisResult& r) {
  return static_cast<int>(std::count_if(r.candidates.begin(), r.candidates.end(),
                                        [](const CandidateResult& c) { return !c.skipped; }));
}
bool anySignificant(const AnalysisResult& r) {
  return std::any_of(r.candidates.begin(), r.candidates.end(), [](const CandidateResult& c) { return c.significant; });
}

// Bonferroni alone. Clean data (the truth is the model plus white noise: every alarm is false),
// 100 seeds, the default menu of candidates, family_alpha = 0.05, and the held-out threshold
// switched off (min_relative_reduction = -inf), so that the correction over the candidates is the
// only guard. Claim (docs/analyze.md): a whole ranking raises a false alarm with probability below
// family_alpha, i.e. about 5 of 100 rankings (12 or more has probability ~0.001). Without the
// correction, a ranking alarms whenever any of its ~11 candidates has p < 0.05 (about 40 of 100).
TEST(LabGuards, BonferroniAloneKeepsTheFamilyFalseAlarmRate) {
  sim::CellSimConfig noisy = labtest::baseConfig(1);
  noisy.duration_s = 4.0;
  sim::CellSimConfig clean = noisy;
  clean.noise = sim::NoiseConfig{};
  const std::vector<SampleContext> ctx0 = labtest::contexts(clean).samples;
  const auto noise = stats_test::simulatorWhiteNoise(noisy);
  AnalyzeOptions o;
  o.model = "paper";
  o.family_alpha = 0.05;
  o.min_relative_reduction = -std::numeric_limits<double>::infinity();
  const int seeds = 100;
  int alarms = 0, uncorrected = 0, tested = 0;
  for (int k = 0; k < seeds; ++k) {
    std::vector<SampleContext> ctx = ctx0;
    std::mt19937_64 rng(9100 + static_cast<std::uint64_t>(k));
    noise(ctx, rng);
    const AnalysisResult r = analyze(ctx, nullptr, o, "sim.csv");
    tested = testedCandidates(r);
    if (anySignificant(r)) ++alarms;
    if (std::any_of(r.candidates.begin(), r.candidates.end(),
                    [&](const CandidateResult& c) { return !c.skipped && c.p_value < o.family_alpha; })) {
      ++uncorrected;
    }
  }
  std::printf("  %d candidates, %d seeds: %d rankings with p < alpha uncorrected, %d false alarms\n", tested, seeds,
              uncorrected, alarms);
  EXPECT_GE(tested, 8);
  // The data set needs the guard: uncorrected, many rankings would alarm.
  EXPECT_GE(uncorrected, 20);
  EXPECT_LE(alarms, 12) << "family-wise false-alarm rate above family_alpha = 0.05";
}

// The held-out condition on coloured noise, and why it has a margin. No effect is missing, but the
// sensor noise is coloured (AR(1), correlation time 10 samples = 80 ms, as strong as the white
// part, beyond the single AR(1) the prewhitening removes): the F test assumes independent rows, so
// on the fitting data several candidates pass even the family-wise p, in every one of 20 seeds.
// One analysis per seed with the held-out condition off gives, for every candidate that passes the
// family-wise p and the constraints, its held-out reduction; the alarms are then counted on the
// same draws with the condition off, as a bare sign constraint (the held-out error must fall) and
// with the rule's margin (AnalyzeOptions::min_relative_reduction, 1 %).
// Measured: 20 of 20 alarm with the condition off, 7 of 20 with the sign constraint alone, 2 of 20
// with the 1 % margin. Claims: the data set needs a guard (>= 15 alarm without), the rule's margin
// keeps it to at most 5 of 20, and the sign constraint alone does not (the reason the margin
// exists, docs/analyze.md). Known limit: no held-out condition makes coloured noise harmless;
// serial correlation is the business of a HAC covariance.
TEST(LabGuards, HeldOutSignConstraintOnColouredNoise) {
  const sim::CellSimConfig noisy = labtest::baseConfig(1);
  sim::CellSimConfig clean = noisy;
  clean.noise = sim::NoiseConfig{};
  const std::vector<SampleContext> ctx0 = labtest::contexts(clean).samples;
  const auto noise = stats_test::both(stats_test::simulatorWhiteNoise(noisy),
                                      stats_test::ar1WrenchNoise(noisy.noise.wrench_std, 0.9));
  AnalyzeOptions o;
  o.model = "paper";
  o.min_relative_reduction = -std::numeric_limits<double>::infinity();
  const int seeds = 20;
  const double rule_margin = AnalyzeOptions{}.min_relative_reduction;
  int off = 0, sign = 0, margin = 0;
  for (int k = 0; k < seeds; ++k) {
    const std::uint64_t seed = 9201 + static_cast<std::uint64_t>(k);
    std::vector<SampleContext> ctx = ctx0;
    std::mt19937_64 rng(seed);
    noise(ctx, rng);
    const AnalysisResult r = analyze(ctx, nullptr, o, "sim.csv");
    int past_bonferroni = 0;
    double best = -1.0;
    for (const auto& c : r.candidates) {
      if (!c.skipped && c.family_p < o.family_alpha) ++past_bonferroni;
      // relative_reduction is clamped to 0..1: > 0 exactly when the held-out error falls.
      if (c.verdict == Verdict::kRecommended) best = std::max(best, c.relative_reduction);
    }
    // The data set needs a guard: Bonferroni lets several candidates through.
    EXPECT_GE(past_bonferroni, 3) << "seed " << seed;
    off += best >= 0.0 ? 1 : 0;
    sign += best > 0.0 ? 1 : 0;
    margin += best > rule_margin ? 1 : 0;
    std::printf("  seed %llu: %d past Bonferroni, best recommended held-out reduction %.4f\n",
                static_cast<unsigned long long>(seed), past_bonferroni, best);
  }
  std::printf("  of %d rankings on coloured noise: %d alarm with the held-out condition off, %d as a sign "
              "constraint, %d with the %.3g margin\n", seeds, off, sign, margin, rule_margin);
  EXPECT_GE(off, 15) << "the data set must need a guard";
  EXPECT_LE(margin, 5) << "the rule's held-out margin should silence most rankings on coloured noise";
  EXPECT_GT(sign, margin) << "the margin exists because the sign constraint alone does not silence them";
}

// --- Ranking by held-out, not in-sample, improvement ---------------------------------------------

// A temperature drift is hidden in the run, and the temperature column is noisy (0.3 degC). The
// true candidate, temperature_drift, is linear in that noisy reading; poly(t,5) is a flexible curve
// in time that follows the smooth temperature profile and the noise (30 parameters): it gains the
// most in-sample, but extrapolated to a held-out block it fails. The ranking must put the true
// effect first and the overfitting candidate last.
TEST(LabRanking, OverfittingCandidateBestInSampleRanksLast) {
  sim::CellSimConfig cfg = labtest::baseConfig(9301);
  cfg.temperature_drift.enabled = true;
  cfg.noise.temp_std = 0.3;
  AnalyzeOptions o;
  o.model = "paper";
  o.candidates = {"temperature_drift", "poly(t,5)", "time_drift", "harmonic(q6,1)"};
  const AnalysisResult r = analyze(labtest::contexts(cfg).samples, nullptr, o, "sim.csv");
  const auto find = [&r](const std::string& name) -> const CandidateResult& {
    for (const auto& c : r.candidates) {
      if (c.effect == name) return c;
    }
    throw std::out_of_range(name);
  };
  for (const auto& c : r.candidates) {
    std::printf("  %-18s in-sample %.4f  held-out %.4f  significant %d\n", c.effect.c_str(), c.fit_relative_reduction,
                c.relative_reduction, c.significant ? 1 : 0);
  }
  const CandidateResult& truth = find("temperature_drift");
  const CandidateResult& overfit = find("poly(t,5)");
  // The data set: the overfitting candidate is the best of all in-sample ...
  for (const auto& c : r.candidates) {
    if (c.effect != overfit.effect) {
      EXPECT_GT(overfit.fit_relative_reduction, c.fit_relative_reduction) << c.effect;
    }
  }
  // ... and worse than the truth held out.
  EXPECT_LT(overfit.relative_reduction, truth.relative_reduction);
  ASSERT_EQ(r.candidates.size(), 4u);
  EXPECT_EQ(r.candidates.front().effect, "temperature_drift");
  EXPECT_TRUE(r.candidates.front().significant);
  EXPECT_EQ(r.candidates.back().effect, "poly(t,5)");
}

}  // namespace
}  // namespace ftid::lab
