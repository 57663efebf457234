// The model laboratory on simulator runs whose truth contains an effect the starting model lacks:
// the hidden effect must be the top significant candidate, adding it must bring the held-out
// residual to within 1.2x the noise floor on every axis, and its identified parameters must match
// the simulator's truth within 4 reported standard errors. Clean runs must raise no alarm.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <random>
#include <cstdlib>
#include <unistd.h>
#include <utility>

#include "ftid/common/error.hpp"

#include "ftid/identify/offline.hpp"
#include "ftid/identify/physical_check.hpp"
#include "ftid/lab/analyze.hpp"
#include "ftid/params/parameter_set.hpp"
#include "ftid/logio/log.hpp"
#include "lab_sim.hpp"
#include "test_paths.hpp"

namespace {

using namespace ftid;
using labtest::analyzeRun;
using labtest::baseConfig;
using labtest::findParam;

void expectHiddenEffectFound(const lab::AnalysisResult& r, const std::string& effect) {
  ASSERT_FALSE(r.candidates.empty());
  EXPECT_EQ(r.candidates.front().effect, effect) << lab::formatText(r);
  EXPECT_TRUE(r.candidates.front().significant) << lab::formatText(r);
  ASSERT_GE(r.steps.size(), 2u) << lab::formatText(r);
  EXPECT_EQ(r.steps[1].added, effect);
  // Nothing else significant after the hidden effect: the path stops there.
  EXPECT_EQ(r.steps.size(), 2u) << lab::formatText(r);
  ASSERT_TRUE(r.final_report.has_value());
  for (int a = 0; a < 6; ++a) {
    EXPECT_LT(r.final_report->residual_rms(a), 1.2 * r.noise_floor(a)) << "axis " << kWrenchAxisNames[a] << "\n"
                                                                         << lab::formatText(r);
  }
  // The starting model really failed somewhere.
  EXPECT_GT((r.report.residual_rms.cwiseQuotient(r.noise_floor)).maxCoeff(), 1.2);
}

void expectParam(const lab::ModelReport& rep, const std::string& name, double truth, double sigmas = 4.0) {
  const auto* p = findParam(rep, name);
  ASSERT_NE(p, nullptr) << name;
  EXPECT_GT(p->std, 0.0) << name;
  EXPECT_LT(std::abs(p->value - truth), sigmas * p->std)
      << name << " = " << p->value << " +- " << p->std << ", truth " << truth;
}

TEST(NoiseFloor, RecoversWhiteNoiseStdAlsoUnderASmoothSignal) {
  std::mt19937_64 gen(3);
  std::normal_distribution<double> n(0.0, 0.3);
  std::vector<double> pure(5000), mixed(5000);
  for (std::size_t i = 0; i < pure.size(); ++i) {
    const double t = static_cast<double>(i) / 125.0;
    pure[i] = n(gen);
    mixed[i] = pure[i] + 20.0 * std::sin(2.0 * M_PI * 1.0 * t) + 5.0 * std::cos(2.0 * M_PI * 2.5 * t);
  }
  EXPECT_NEAR(lab::estimateNoiseStd(pure), 0.3, 0.3 * 0.04);
  EXPECT_NEAR(lab::estimateNoiseStd(mixed), 0.3, 0.3 * 0.05);
  EXPECT_THROW(lab::estimateNoiseStd(std::vector<double>(5, 0.0)), DataError);
}

TEST(Statistics, ChiSquareSurvivalMatchesTables) {
  EXPECT_NEAR(lab::chiSquareSurvival(3.841458820694124, 1), 0.05, 1e-9);
  EXPECT_NEAR(lab::chiSquareSurvival(18.30703805327515, 10), 0.05, 1e-9);
  EXPECT_NEAR(lab::chiSquareSurvival(50.89218131151707, 30), 0.01, 1e-9);
  EXPECT_NEAR(lab::chiSquareSurvival(2.0, 2), std::exp(-1.0), 1e-12);
  EXPECT_EQ(lab::chiSquareSurvival(0.0, 3), 1.0);
}

// The p-value with an uncertain scale, against draws of its own model (independent: a simulation,
// not the quadrature): statistic = exp(s z) chi2(q), z standard normal. Its p-values are uniform
// (the fractions below 0.05 and 0.01 within 4 binomial standard deviations), where the plain
// chi-square tail's are not for many degrees of freedom (q = 12: about 7 % below 0.05; for q = 1 the
// scale matters little).
TEST(Statistics, UncertainScaleSurvivalIsUniformUnderItsModel) {
  EXPECT_EQ(lab::chiSquareSurvivalUncertainScale(7.0, 3, 0.0), lab::chiSquareSurvival(7.0, 3));
  std::mt19937_64 rng(2026);
  std::normal_distribution<double> n01(0.0, 1.0);
  const int draws = 4000;
  for (const auto& [q, s] : {std::pair<int, double>{1, 0.3}, {12, 0.2}}) {
    std::chi_squared_distribution<double> chi2(q);
    int below05 = 0, below01 = 0, plain05 = 0;
    for (int k = 0; k < draws; ++k) {
      const double x = std::exp(s * n01(rng)) * chi2(rng);
      const double p = lab::chiSquareSurvivalUncertainScale(x, q, s);
      below05 += p < 0.05 ? 1 : 0;
      below01 += p < 0.01 ? 1 : 0;
      plain05 += lab::chiSquareSurvival(x, q) < 0.05 ? 1 : 0;
    }
    std::printf("  q %d, s %.2f: %d / %d below 0.05 (plain chi-square: %d), %d below 0.01\n", q, s, below05, draws,
                plain05, below01);
    EXPECT_LT(std::abs(below05 - 0.05 * draws), 4.0 * std::sqrt(0.05 * 0.95 * draws)) << "q " << q;
    EXPECT_LT(std::abs(below01 - 0.01 * draws), 4.0 * std::sqrt(0.01 * 0.99 * draws)) << "q " << q;
    if (q >= 12) {
      EXPECT_GT(plain05 - 0.05 * draws, 4.0 * std::sqrt(0.05 * 0.95 * draws)) << "q " << q;
    }
  }
}

// The held-out test's tail P(sum_k lambda_k chi2_1 >= x), against independent formulations: the
// exact chi-square tail when every weight is 1 (a sum of k chi2_1 is chi2_k), and a seeded Monte
// Carlo of the sum itself for weights of both signs (the law of a held-out gain).
TEST(Statistics, WeightedChiSquareTailMatchesChiSquareAndSimulation) {
  for (int k : {1, 3, 12}) {
    const std::vector<double> ones(static_cast<std::size_t>(k), 1.0);
    for (double x : {k + 3.0 * std::sqrt(2.0 * k), 30.0 + k, 100.0 + 3.0 * k, 600.0}) {
      const double exact = lab::chiSquareSurvival(x, k);
      const double approx = lab::weightedChiSquareSurvival(ones, x);
      // Lugannani-Rice is least accurate for a single weight (about 14 % at 1e-132, measured).
      EXPECT_NEAR(approx / exact, 1.0, k == 1 ? 0.15 : 0.06) << "k " << k << " x " << x << ": " << approx << " vs " << exact;
    }
  }
  const std::vector<double> lambda = {3.0, 1.2, 0.5, 0.1, -0.4, -1.5, -2.5};
  std::mt19937_64 rng(77);
  std::normal_distribution<double> n01(0.0, 1.0);
  const int draws = 1000000;
  std::vector<double> q(draws);
  for (auto& v : q) {
    v = 0.0;
    for (double l : lambda) {
      const double z = n01(rng);
      v += l * z * z;
    }
  }
  for (double x : {4.0, 12.0, 20.0, 28.0}) {
    const double frac = static_cast<double>(std::count_if(q.begin(), q.end(), [x](double v) { return v >= x; })) / draws;
    const double p = lab::weightedChiSquareSurvival(lambda, x);
    const double se = std::sqrt(frac * (1.0 - frac) / draws);
    std::printf("  x %5.1f: simulated %.3e +- %.1e, saddlepoint %.3e\n", x, frac, se, p);
    EXPECT_NEAR(p, frac, 4.0 * se + 0.05 * frac) << "x " << x;
  }
  EXPECT_EQ(lab::weightedChiSquareSurvival({-1.0, -2.0}, 1.0), 1.0);  // cannot exceed 0 by chance: no claim
  EXPECT_EQ(lab::weightedChiSquareSurvivalUncertainScale(lambda, 12.0, 0.0), lab::weightedChiSquareSurvival(lambda, 12.0));
}

TEST(Analyze, CleanRunsRaiseNoAlarm) {
  // Several seeds: the truth is the paper model plus noise; no candidate may be significant.
  for (std::uint64_t seed : {11u, 12u, 13u}) {
    const auto r = analyzeRun(baseConfig(seed), "paper", true);
    for (const auto& c : r.candidates) EXPECT_FALSE(c.significant) << "seed " << seed << "\n" << lab::formatText(r);
    EXPECT_EQ(r.steps.size(), 1u);
    for (int a = 0; a < 6; ++a) {
      EXPECT_LT(r.report.residual_rms(a), 1.2 * r.noise_floor(a));
      const double true_noise = a < 3 ? 0.05 : 0.01;
      EXPECT_NEAR(r.noise_floor(a), true_noise, 0.1 * true_noise);
    }
  }
}

TEST(Analyze, FindsHiddenRigidBodyAndTheInertiaAboutTheCentreOfMass) {
  auto cfg = baseConfig(21);
  cfg.full_rigid_body = true;
  const auto r = analyzeRun(cfg, "paper", true);
  expectHiddenEffectFound(r, "rigid_body");
  const auto& rep = *r.final_report;
  const Mat3& I = cfg.payload.I_C_S;
  expectParam(rep, "i_c_xx", I(0, 0));
  expectParam(rep, "i_c_yy", I(1, 1));
  expectParam(rep, "i_c_zz", I(2, 2));
  expectParam(rep, "i_c_xy", I(0, 1));
  expectParam(rep, "i_c_xz", I(0, 2));
  expectParam(rep, "i_c_yz", I(1, 2));
  expectParam(rep, "mass", cfg.payload.mass_kg);
  ASSERT_TRUE(rep.inertia.has_value());
  EXPECT_TRUE(rep.inertia->valid_within_uncertainty);
}

TEST(Analyze, FindsHiddenCableAndItsStiffness) {
  auto cfg = baseConfig(31);
  cfg.cable.enabled = true;
  cfg.cable.stiffness_N_per_m = 4.0;
  const auto r = analyzeRun(cfg, "paper", true);
  expectHiddenEffectFound(r, "cable");
  const auto& rep = *r.final_report;
  const double k = cfg.cable.stiffness_N_per_m;
  expectParam(rep, "cable_k", k);
  expectParam(rep, "cable_ka_x", k * cfg.cable.p_SA_S.x());
  expectParam(rep, "cable_ka_y", k * cfg.cable.p_SA_S.y());
  expectParam(rep, "cable_ka_z", k * cfg.cable.p_SA_S.z());
}

TEST(Analyze, FindsHiddenTemperatureDrift) {
  auto cfg = baseConfig(41);
  cfg.temperature_drift.enabled = true;
  cfg.temperature_drift.reference_degC = 25.0;
  const auto r = analyzeRun(cfg, "paper", true);
  expectHiddenEffectFound(r, "temperature_drift");
  const auto& rep = *r.final_report;
  const char* ax[3] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    expectParam(rep, std::string("f0_dtemp_") + ax[i], cfg.temperature_drift.dF0_dT_N_per_degC(i));
    expectParam(rep, std::string("t0_dtemp_") + ax[i], cfg.temperature_drift.dT0_dT_Nm_per_degC(i));
  }
}

TEST(Analyze, TellsTimeDriftFromTemperatureDrift) {
  // The simulator's temperature rises and oscillates (not monotonic in time).
  auto cfg = baseConfig(51);
  cfg.time_drift.enabled = true;
  const auto r = analyzeRun(cfg, "paper", true);
  expectHiddenEffectFound(r, "time_drift");
  const auto& rep = *r.final_report;
  const char* ax[3] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    expectParam(rep, std::string("f0_dt_") + ax[i], cfg.time_drift.dF0_dt_N_per_s(i));
    expectParam(rep, std::string("t0_dt_") + ax[i], cfg.time_drift.dT0_dt_Nm_per_s(i));
  }
  // And the other way round: the temperature run does not pick time.
  auto cfg2 = baseConfig(52);
  cfg2.temperature_drift.enabled = true;
  const auto r2 = analyzeRun(cfg2, "paper", false);
  EXPECT_EQ(r2.candidates.front().effect, "temperature_drift");
  EXPECT_GT(r2.candidates.front().relative_reduction, r2.candidates[1].relative_reduction);
}

TEST(Analyze, FindsHiddenSensorDelay) {
  auto cfg = baseConfig(61);
  cfg.sensor_delay.enabled = true;
  cfg.sensor_delay.tau_s = 0.012;
  const auto r = analyzeRun(cfg, "paper", true);
  expectHiddenEffectFound(r, "sensor_delay");
  expectParam(*r.final_report, "delay", cfg.sensor_delay.tau_s);
}

TEST(Analyze, ExternalValidationLogAndErrors) {
  auto cfg = baseConfig(71);
  const auto fit = labtest::contexts(cfg);
  cfg.seed = 72;
  const auto val = labtest::contexts(cfg);
  lab::AnalyzeOptions o;
  const auto r = lab::analyze(fit.samples, &val.samples, o, "a.csv", "b.csv");
  EXPECT_EQ(r.n_eval, static_cast<int>(val.samples.size()));
  for (int a = 0; a < 6; ++a) EXPECT_LT(r.report.residual_rms(a), 1.2 * r.noise_floor(a));
  o.model = "paper+no_such_effect";
  EXPECT_THROW(lab::analyze(fit.samples, nullptr, o), ConfigError);
  o.model = "paper";
  std::vector<effects::SampleContext> few(fit.samples.begin(), fit.samples.begin() + 30);
  EXPECT_THROW(lab::analyze(few, nullptr, o), DataError);
}

TEST(Analyze, JsonHasTheDocumentedKeys) {
  auto cfg = baseConfig(81);
  cfg.time_drift.enabled = true;
  const auto r = analyzeRun(cfg, "paper", true);
  const std::string j = lab::formatJson(r);
  for (const char* key : {"\"model\"", "\"residual_rms\"", "\"noise_floor\"", "\"candidates\"", "\"effect\"",
                          "\"relative_reduction\"", "\"significant\"", "\"steps\"", "\"fx\"", "\"tz\""}) {
    EXPECT_NE(j.find(key), std::string::npos) << key;
  }
  EXPECT_NE(j.find("--model paper+time_drift"), std::string::npos);
}

// Every suggested command can be pasted into a shell: the shell splits it into the words meant.
// And when nothing is recommended, the table says for each candidate why, in words.
TEST(Analyze, SuggestedCommandsPasteIntoAShellAndEveryVerdictHasItsReason) {
  const auto r = analyzeRun(baseConfig(91), "paper", false);
  int harmonics = 0;
  for (const auto& c : r.candidates) {
    if (c.skipped) continue;
    EXPECT_FALSE(c.significant) << lab::formatText(r);
    EXPECT_FALSE(c.reason.empty()) << c.effect;
    // The printed family-wise p is min(1, m p) with the analysis' one m.
    if (c.added_params > 0) {
      EXPECT_DOUBLE_EQ(c.family_p, std::min(1.0, r.family_size * c.p_value)) << c.effect;
    }
    EXPECT_NE(lab::formatText(r).find("  " + c.effect + ": " + lab::verdictWord(c.verdict)), std::string::npos)
        << c.effect << "\n" << lab::formatText(r);
    if (c.effect.find('(') == std::string::npos) continue;
    ++harmonics;
    // printf '%s\n' <the command's words>: one line per word as the shell splits them.
    const std::string cmd = "printf '%s\\n' " + c.next_command;
    FILE* p = popen(cmd.c_str(), "r");
    ASSERT_NE(p, nullptr);
    char buf[512] = {0};
    const std::size_t got = fread(buf, 1, sizeof(buf) - 1, p);
    EXPECT_EQ(pclose(p), 0) << cmd;
    EXPECT_EQ(std::string(buf, got), "ftid\nanalyze\nsim.csv\n--model\npaper+" + c.effect + "\n") << cmd;
    EXPECT_NE(lab::renderHtml(r).find(c.next_command), std::string::npos) << c.next_command;
  }
  EXPECT_GE(harmonics, 3);
  EXPECT_NE(lab::formatText(r).find("nothing is missing: no candidate is recommended. Why each was not taken:"),
            std::string::npos);
}

// Impossible answers are never exported: a payload lighter than the cable's upward pull gives the
// paper model (which lacks the cable) a negative mass; the lab says so and gives no advice to
// write parameters from it.
TEST(Analyze, AnUnphysicalModelIsNamedAndNotExported) {
  auto cfg = baseConfig(92);
  cfg.payload.mass_kg = 0.3;
  cfg.cable.enabled = true;
  cfg.cable.stiffness_N_per_m = 20.0;
  lab::AnalyzeOptions o;
  o.model = "paper";
  o.explain = true;
  o.max_explain_steps = 0;  // stay at the (impossible) starting model
  const auto set = labtest::contexts(cfg);
  const auto r = lab::analyze(set.samples, nullptr, o, "sim.csv");
  const auto* m = findParam(r.report, "mass");
  ASSERT_NE(m, nullptr);
  ASSERT_LT(m->value, 0.0) << "the case needs a negative mass\n" << lab::formatText(r);
  ASSERT_FALSE(r.unphysical.empty()) << lab::formatText(r);
  EXPECT_NE(r.unphysical[0].find("mass"), std::string::npos);
  const std::string text = lab::formatText(r);
  EXPECT_EQ(text.find("--out params.yaml"), std::string::npos) << text;
  EXPECT_NE(text.find("not physically possible"), std::string::npos) << text;
  EXPECT_NE(text.find("the path stops at paper at the step limit"), std::string::npos) << text;
  // The whole path takes the cable (this run's truth) and ends at a physical model at the noise
  // floor, with the advice to write it. (Before the fits were weighted by the floor the report
  // prints, analyze.cpp, the weights of the readings' first estimate left the light payload's tilt
  // undetermined with the cable, and the path ended at the impossible paper model.)
  o.max_explain_steps = 6;
  const auto r2 = lab::analyze(set.samples, nullptr, o, "sim.csv");
  ASSERT_TRUE(r2.final_report.has_value());
  EXPECT_EQ(r2.final_report->model, "paper+cable") << lab::formatText(r2);
  EXPECT_TRUE(r2.unphysical.empty()) << lab::formatText(r2);
  const auto* m2 = findParam(*r2.final_report, "mass");
  ASSERT_NE(m2, nullptr);
  EXPECT_NEAR(m2->value, cfg.payload.mass_kg, 4.0 * m2->std);
  EXPECT_NE(lab::formatText(r2).find("--out params.yaml"), std::string::npos) << lab::formatText(r2);
}

// What `ftid identify --out` does with a model (apps/ftid/cmd_identify.cpp): fit with the IMU as
// its default, project an inertia within its uncertainty, then the physical validity check.
bool identifyWouldWrite(const samples::ContextSet& set, const std::string& model) {
  identify::IdentifyRequest req;
  req.model = model;
  req.log_path = "sim.csv";
  req.imu = identify::IdentifyRequest::ImuUse::kAuto;
  identify::CheckedIdentification id = identify::identifyContextsChecked(set, req, /*check=*/false);
  params::projectInertiaWithinUncertainty(&id.set);
  return identify::checkPhysicalValidity(id.set, id.varying_mass).valid;
}

// The lab's advice to write parameters agrees with identify (docs/analyze.md, "Advice to write
// parameters"). The simulator's default 10 s paper-style run (joints 4-6) with a hidden
// temperature drift and coloured noise: the path ends at a model with rigid_body whose inertia
// this motion does not determine. Possible within its errors, so the verdict keeps it; but
// identify refuses to write it, so the lab must not advise `--out` for it, and the alternative it
// offers (without rigid_body) must be one identify writes.
TEST(Analyze, ExplainAdvisesOnlyAModelIdentifyWrites) {
  sim::CellSimConfig c = sim::paperCellConfig(labtest::robot());
  c.seed = 7;
  c.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  c.noise.wrench_lowpass_hz = 5.0;
  c.temperature_drift.enabled = true;
  c.temperature_drift.dF0_dT_N_per_degC = Vec3(0.05, 0.0, 0.1);
  const samples::ContextSet set = labtest::contexts(c);
  lab::AnalyzeOptions o;
  o.model = "paper";
  o.explain = true;
  const lab::AnalysisResult r = lab::analyze(set.samples, nullptr, o, "sim.csv");
  const std::string text = lab::formatText(r);
  ASSERT_FALSE(r.steps.empty());
  const std::string last = r.steps.back().model;
  ASSERT_TRUE(r.unphysical.empty()) << text;
  ASSERT_NE(last.find("temperature_drift"), std::string::npos) << text;
  ASSERT_FALSE(r.unwritable.empty()) << "the case needs a model identify does not write\n" << text;
  EXPECT_FALSE(identifyWouldWrite(set, last)) << "the lab says identify refuses " << last;
  EXPECT_EQ(text.find("--model " + lab::shellQuote(last) + " --out"), std::string::npos) << text;
  ASSERT_FALSE(r.writable_alternative.empty()) << text;
  EXPECT_EQ(r.writable_alternative.find("rigid_body"), std::string::npos);
  EXPECT_NE(text.find("--model " + lab::shellQuote(r.writable_alternative) + " --out params.yaml"),
            std::string::npos) << text;
  EXPECT_TRUE(identifyWouldWrite(set, r.writable_alternative)) << r.writable_alternative;
}

// One family size m for the whole analysis: the menu's effects that can be tried on this data,
// whatever the starting model. From `paper` it is the count of candidates not skipped (none is in
// the model); from a start that already holds two of them it is the same m, and every printed
// family-wise p of the ranking, of the path's steps and of the final verdicts is min(1, m p).
TEST(Analyze, TheFamilyOfTheCorrectionDoesNotDependOnTheStart) {
  auto cfg = baseConfig(93);
  cfg.cable.enabled = true;
  cfg.cable.stiffness_N_per_m = 3.0;
  lab::AnalyzeOptions o;
  o.candidates = {"cable", "time_drift", "temperature_drift", "harmonic(q6,1)"};
  o.explain = true;
  o.max_explain_steps = 3;
  const auto set = labtest::contexts(cfg);
  o.model = "paper";
  const auto a = lab::analyze(set.samples, nullptr, o, "sim.csv");
  const int tried = static_cast<int>(std::count_if(a.candidates.begin(), a.candidates.end(),
                                                   [](const lab::CandidateResult& c) { return !c.skipped; }));
  EXPECT_EQ(a.family_size, tried) << lab::formatText(a);
  o.model = "paper+time_drift+cable";
  const auto b = lab::analyze(set.samples, nullptr, o, "sim.csv");
  EXPECT_EQ(b.family_size, a.family_size) << lab::formatText(b);
  const auto expectM = [](const lab::AnalysisResult& r, double p, double family_p, const std::string& what) {
    if (p < 1.0) {
      EXPECT_DOUBLE_EQ(family_p, std::min(1.0, r.family_size * p)) << what << "\n" << lab::formatText(r);
    }
  };
  for (const auto* r : {&a, &b}) {
    for (const auto& c : r->candidates) {
      if (c.added_params > 0) expectM(*r, c.p_value, c.family_p, c.effect);
    }
    for (std::size_t k = 1; k < r->steps.size(); ++k) expectM(*r, r->steps[k].p_value, r->steps[k].family_p, "step");
    EXPECT_NE(lab::formatText(*r).find("min(1, " + std::to_string(r->family_size) + " p)"), std::string::npos);
  }
}

}  // namespace

// `ftid analyze LOG --validate LOG2` on logs with a host_time column: the model time t of LOG2
// counts from LOG's origin (docs/conventions.md, "Time and logs"), as ftidd and `ftid compensate`
// would with the parameters identified from LOG. One 20 s run with a linear time drift, cut into
// two logs: fitted on the first 10 s, validated on the last 10 s. With LOG2's own origin the
// drift would restart at 0 there, an offset error of 10 s times the rate (0.3 N on fz, 6x the noise).
namespace {
logio::LogData sliceWithHostTime(const logio::LogData& log, std::size_t a, std::size_t b, bool host_time,
                                 const std::string& source) {
  logio::LogData out = log;
  out.source = source;
  out.samples.assign(log.samples.begin() + static_cast<std::ptrdiff_t>(a),
                     log.samples.begin() + static_cast<std::ptrdiff_t>(b));
  for (auto& col : out.extra_columns) {
    col.assign(col.begin() + static_cast<std::ptrdiff_t>(a), col.begin() + static_cast<std::ptrdiff_t>(b));
  }
  if (host_time) {
    out.extra_names.push_back("host_time");
    std::vector<double> h;
    for (const auto& s : out.samples) h.push_back(1.7e9 + s.t);  // the host clock, 1:1 with the controller's
    out.extra_columns.push_back(h);
  }
  return out;
}
}  // namespace

TEST(AnalyzeFiles, ValidationLogsModelTimeCountsFromTheFittedLogsOrigin) {
  auto cfg = baseConfig(53);
  cfg.duration_s = 20.0;
  cfg.time_drift.enabled = true;
  const logio::LogData run = sim::CellSim(cfg).run();
  const std::size_t half = run.samples.size() / 2;
  char dir_template[] = "/tmp/ftid-validate-origin.XXXXXX";
  ASSERT_NE(mkdtemp(dir_template), nullptr);
  const std::string dir = dir_template;
  const std::string fit_path = dir + "/fit.csv";
  const std::string val_path = dir + "/validate.csv";
  const std::string val_plain_path = dir + "/validate_no_host_time.csv";
  logio::writeLog(fit_path, sliceWithHostTime(run, 0, half, true, fit_path));
  logio::writeLog(val_path, sliceWithHostTime(run, half, run.samples.size(), true, val_path));
  logio::writeLog(val_plain_path, sliceWithHostTime(run, half, run.samples.size(), false, val_plain_path));

  lab::AnalyzeFilesRequest req;
  req.log_path = fit_path;
  req.validate_path = val_path;
  req.robot_urdf = ftid::test::sourcePath("/config/ur10.urdf");
  req.options.model = "paper+time_drift";
  req.context = {cfg.R_FS, cfg.p_FS_F, 0.0, 0.0};
  const lab::AnalysisResult r = lab::analyzeLogFiles(req);
  for (int a = 0; a < 6; ++a) {
    EXPECT_LT(r.report.residual_rms(a), 1.2 * r.noise_floor(a)) << "axis " << kWrenchAxisNames[a] << "\n"
                                                                << lab::formatText(r);
  }
  // Only one log on the host clock: refused (its columns differ), never compared on two clocks.
  req.validate_path = val_plain_path;
  EXPECT_THROW(lab::analyzeLogFiles(req), DataError);
  for (const std::string& p : {fit_path, val_path, val_plain_path}) std::remove(p.c_str());
  rmdir(dir.c_str());
}
