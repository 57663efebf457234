// Extra log columns as candidate signals (docs/analyze.md, "Extra columns as candidate signals"),
// on simulator runs with full rigid-body physics: a 0.3 kg gripper jaw moving along the tool's x
// axis with the logged column `grip`, its wrench computed with its own physics (jaw_sim.hpp: a
// point mass at its momentary position, including its motion relative to the tool), the
// laboratory not told; and clean runs with an unrelated column (no false alarm).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "ftid/identify/fit.hpp"
#include "jaw_sim.hpp"
#include "lab_sim.hpp"

namespace ftid {
namespace {

using jawtest::kJawMass;
using jawtest::kJawTravel;
using jawtest::kPi;

/// A run of the lab's cell (full rigid body) with one extra column: `grip` (and the jaw's wrench in
/// the reading) when `with_jaw`; else `valve`, unrelated to the physics: a slow random walk for
/// even seeds, a slow sine of random phase for odd ones.
samples::ContextSet run(std::uint64_t seed, bool with_jaw, double duration_s = 10.0) {
  auto c = labtest::baseConfig(seed);
  c.full_rigid_body = true;
  c.duration_s = duration_s;
  const sim::CellSim s(c);
  logio::LogData log = s.run();
  std::vector<double> column;
  std::mt19937_64 rng(seed + 77);
  std::normal_distribution<double> step(0.0, 0.02);
  const double phase = std::uniform_real_distribution<double>(0.0, 2.0 * kPi)(rng);
  double walk = 0.0;
  if (with_jaw) {
    jawtest::addJaw(s, log);
  } else {
    for (const auto& sample : log.samples) {
      walk += step(rng);
      column.push_back(seed % 2 == 0 ? walk : std::sin(2.0 * kPi * 0.13 * sample.t + phase));
    }
    log.extra_names.emplace_back("valve");
    log.extra_columns.push_back(column);
  }
  return samples::buildContexts(log, *c.robot, {c.R_FS, c.p_FS_F, 0.0, 0.0});
}

const lab::CandidateResult* candidate(const std::vector<lab::CandidateResult>& list, const std::string& effect) {
  for (const auto& c : list) {
    if (c.effect == effect) return &c;
  }
  return nullptr;
}

TEST(ExtraSignalSim, AJawMovingWithGripIsNamedThroughItsSignal) {
  const auto set = run(2201, true);
  lab::AnalyzeOptions o;
  o.model = "paper+rigid_body";
  o.explain = true;
  const lab::AnalysisResult r = lab::analyze(set.samples, nullptr, o, "jaw.csv");
  const std::string text = lab::formatText(r);
  if (std::getenv("FTID_TEST_PRINT") != nullptr) std::cout << text;
  // Named through its signal: recommended in the ranking and taken by the path.
  const auto* jaw = candidate(r.candidates, "payload(grip)");
  ASSERT_NE(jaw, nullptr) << text;
  EXPECT_EQ(jaw->verdict, lab::Verdict::kRecommended) << text;
  EXPECT_EQ(r.candidates.front().effect, "payload(grip)") << text;
  bool taken = false;
  for (const auto& st : r.steps) taken = taken || st.added == "payload(grip)";
  EXPECT_TRUE(taken) << text;
  ASSERT_TRUE(r.final_report.has_value());
  // The path ends in rigid_body and the jaw. payload(grip) models the jaw's mass and first moment,
  // not the inertia its travel adds, and with 1,251 samples that leaves a residual the held-out
  // test finds beyond chance (docs/analyze.md): measured, the path then also takes `mounting`
  // (0.07 deg, held-out sum of squares -0.5 %), the menu's best stand-in. Whatever it takes after
  // the jaw, it is the same from either start.
  const std::string& end = r.final_report->model;
  EXPECT_EQ(end.rfind("paper+rigid_body+", 0), 0u) << text;
  EXPECT_NE(end.find("payload(grip)"), std::string::npos) << text;
  // The same end from the paper's model (rigid_body first, then the jaw).
  o.model = "paper";
  const lab::AnalysisResult from_paper = lab::analyze(set.samples, nullptr, o, "jaw.csv");
  ASSERT_TRUE(from_paper.final_report.has_value());
  EXPECT_EQ(from_paper.final_report->model, end) << lab::formatText(from_paper);
  // The residual to within 1.3x the noise on every axis.
  for (int a = 0; a < 6; ++a) {
    EXPECT_LT(r.final_report->residual_rms(a) / r.noise_floor(a), 1.3) << kWrenchAxisNames[a] << "\n" << text;
  }
  // The jaw's first moment per unit of grip: 0.3 kg x d, within four standard errors; its mass
  // does not change (0).
  const char* names[4] = {"dmass_grip", "dmass_com_grip_x", "dmass_com_grip_y", "dmass_com_grip_z"};
  const double truth[4] = {0.0, kJawMass * kJawTravel.x(), kJawMass * kJawTravel.y(), kJawMass * kJawTravel.z()};
  for (int k = 0; k < 4; ++k) {
    const auto* p = labtest::findParam(*r.final_report, names[k]);
    ASSERT_NE(p, nullptr) << names[k] << "\n" << text;
    EXPECT_GT(p->std, 0.0) << names[k];
    EXPECT_LT(std::abs(p->value - truth[k]), 4.0 * p->std) << names[k] << " " << p->value << " +- " << p->std;
  }
  // The column is among the correlations' signals and the report names the candidate.
  bool grip_correlated = false;
  for (const auto& c : r.correlations) grip_correlated = grip_correlated || c.signal == "grip";
  EXPECT_TRUE(grip_correlated) << text;
  EXPECT_NE(text.find("payload(grip)"), std::string::npos);
  EXPECT_EQ(r.extra_signals, std::vector<std::string>{"grip"});
  EXPECT_NE(text.find("extra log columns taken as signals (correlations; candidates payload(C), poly(C,1)): grip"),
            std::string::npos);
  const auto json = nlohmann::json::parse(lab::formatJson(r));
  EXPECT_EQ(json.at("extra_signals"), nlohmann::json::array({"grip"}));
}

// The fitted jaw against the truth over 20 noise seeds (paper+rigid_body+payload(grip), the fit the
// laboratory ends in): the first moment per unit of grip within three standard errors of 0.3 kg x d
// on every seed, and on average within 2 % of it. (Measured: z from -2.3 to +1.5, mean -0.9: a bias
// of about one standard error, 1 %, from what the effect leaves out, the jaw's moving inertia and
// its motion relative to the tool; docs/effects.md.)
TEST(ExtraSignalSim, TheJawsFirstMomentMatchesTheTruthWithinItsStandardErrorOverSeeds) {
  const effects::Model model = effects::Model::fromName("paper+rigid_body+payload(grip)");
  const int col = model.paramIndex().column("dmass_com_grip_x");
  ASSERT_GE(col, 0);
  const double truth = kJawMass * kJawTravel.x();
  constexpr int kSeeds = 20;
  double mean_relative = 0.0;
  for (std::uint64_t seed = 5200; seed < 5200 + kSeeds; ++seed) {
    const auto set = run(seed, true, 6.0);
    const identify::FitResult fit = identify::fitModel(model, set.samples);
    const double z = (fit.theta(col) - truth) / fit.theta_std(col);
    EXPECT_LT(std::abs(z), 3.0) << "seed " << seed << ": " << fit.theta(col) << " +- " << fit.theta_std(col);
    mean_relative += (fit.theta(col) - truth) / truth / kSeeds;
    if (std::getenv("FTID_TEST_PRINT") != nullptr) std::cout << "seed " << seed << " z " << z << "\n";
  }
  EXPECT_LT(std::abs(mean_relative), 0.02);
}

// A user names the signal's effect with --candidates: judged by the same rule, recommended.
TEST(ExtraSignalSim, AUserNamedPayloadCandidateIsRecommended) {
  const auto set = run(2202, true, 6.0);
  lab::AnalyzeOptions o;
  o.model = "paper+rigid_body";
  o.candidates = {"payload(grip)", "poly(grip,1)"};
  const lab::AnalysisResult r = lab::analyze(set.samples, nullptr, o, "jaw.csv");
  EXPECT_EQ(r.family_size, 2);  // the user's menu only
  const auto* jaw = candidate(r.candidates, "payload(grip)");
  ASSERT_NE(jaw, nullptr);
  EXPECT_EQ(jaw->verdict, lab::Verdict::kRecommended) << lab::formatText(r);
  // poly adds offsets linear in grip: it cannot describe a mass whose weight turns with the pose.
  const auto* poly = candidate(r.candidates, "poly(grip,1)");
  ASSERT_NE(poly, nullptr);
  EXPECT_GT(jaw->relative_reduction, poly->relative_reduction) << lab::formatText(r);
  EXPECT_EQ(r.candidates.front().effect, "payload(grip)") << lab::formatText(r);
}

// Clean runs with an unrelated extra column (a slow random walk or sine): its candidates are tried
// (they are in the family) and never recommended. 50 seeds of 6 s runs, ranking only (~6 s).
TEST(ExtraSignalSim, AnUnrelatedColumnRaisesNoFalseAlarm) {
  constexpr int kSeeds = 50;
  int tried = 0;
  for (std::uint64_t seed = 3100; seed < 3100 + kSeeds; ++seed) {
    const auto set = run(seed, false, 6.0);
    lab::AnalyzeOptions o;
    o.model = "paper+rigid_body";
    const lab::AnalysisResult r = lab::analyze(set.samples, nullptr, o, "clean.csv");
    for (const char* e : {"payload(valve)", "poly(valve,1)"}) {
      const auto* c = candidate(r.candidates, e);
      ASSERT_NE(c, nullptr) << e << " not in the menu";
      EXPECT_FALSE(c->skipped) << c->note;
      tried += c->skipped ? 0 : 1;
      EXPECT_NE(c->verdict, lab::Verdict::kRecommended) << "seed " << seed << " " << e << "\n" << lab::formatText(r);
    }
  }
  EXPECT_EQ(tried, 2 * kSeeds);
}

}  // namespace
}  // namespace ftid
