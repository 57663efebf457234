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

// The rule's held-out test on noise the noise model misdescribes. No effect is missing, but the
// sensor noise is coloured beyond the single AR(1) the prewhitening removes (AR(1) with a
// correlation time of 10 samples = 80 ms, as strong as the white part), so every test that takes
// the whitened rows as independent is anti-conservative here. Counted over 20 seeds: rankings in
// which some candidate that is identifiable and physical passes the family-wise p of the in-sample
// nested-model test (q F against chi2(q), what the rule decided on before the held-out test), and
// rankings the rule alarms on (the family-wise p of the held-out gain, docs/analyze.md).
// Measured: 20 of 20 in-sample, 5 of 20 held-out. Claims: the data set is hard (>= 15 alarm
// in-sample), and the held-out test alarms on at most half as many. Known limit (docs/analyze.md):
// with a noise model this wrong, false alarms stay above family_alpha.
TEST(LabGuards, HeldOutTestOnNoiseTheNoiseModelMisdescribes) {
  const sim::CellSimConfig noisy = labtest::baseConfig(1);
  sim::CellSimConfig clean = noisy;
  clean.noise = sim::NoiseConfig{};
  const std::vector<SampleContext> ctx0 = labtest::contexts(clean).samples;
  const auto noise = stats_test::both(stats_test::simulatorWhiteNoise(noisy),
                                      stats_test::ar1WrenchNoise(noisy.noise.wrench_std, 0.9));
  AnalyzeOptions o;
  o.model = "paper";
  const int seeds = 20;
  int in_sample = 0, held_out = 0;
  for (int k = 0; k < seeds; ++k) {
    const std::uint64_t seed = 9201 + static_cast<std::uint64_t>(k);
    std::vector<SampleContext> ctx = ctx0;
    std::mt19937_64 rng(seed);
    noise(ctx, rng);
    const AnalysisResult r = analyze(ctx, nullptr, o, "sim.csv");
    int past_in_sample = 0;
    for (const auto& c : r.candidates) {
      if (c.skipped || c.added_params <= 0 || c.verdict == Verdict::kRefused) continue;
      const double p_in = chiSquareSurvival(c.f_statistic * c.added_params, c.added_params);
      if (std::min(1.0, r.family_size * p_in) < o.family_alpha) ++past_in_sample;
    }
    in_sample += past_in_sample > 0 ? 1 : 0;
    held_out += anySignificant(r) ? 1 : 0;
    std::printf("  seed %llu: %d candidates past the in-sample family-wise p, rule %s\n",
                static_cast<unsigned long long>(seed), past_in_sample, anySignificant(r) ? "ALARMS" : "quiet");
  }
  std::printf("  of %d rankings on mis-described coloured noise: %d alarm in-sample, %d under the rule's held-out test\n",
              seeds, in_sample, held_out);
  EXPECT_GE(in_sample, 15) << "the data set must be hard for a test that takes the rows as independent";
  EXPECT_LE(2 * held_out, in_sample) << "the held-out test should alarm on at most half as many";
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
