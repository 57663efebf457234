// The laboratory's one decision rule (include/ftid/lab/verdict.hpp): each branch of the rule, the
// identifiability and physics checks on hand-made fits, angle wrapping and shell quoting.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "ftid/effects/model.hpp"
#include "ftid/lab/verdict.hpp"

namespace ftid {
namespace {

using lab::Verdict;

lab::RuleInputs significantInputs() {
  lab::RuleInputs in;
  in.p_value = 1e-9;
  in.family_size = 10;
  in.family_alpha = 1e-3;
  in.heldout_reduction = 0.5;
  in.min_heldout_reduction = 0.01;
  in.added_params = 3;
  return in;
}

TEST(Verdict, TheFamilyWisePValueDecidesAndIsMTimesP) {
  auto in = significantInputs();
  auto d = lab::decide(in);
  EXPECT_EQ(d.verdict, Verdict::kRecommended);
  EXPECT_DOUBLE_EQ(d.family_p, 1e-8);
  EXPECT_TRUE(d.reason.empty());
  // Just above alpha / m: not significant, whatever else holds; the reason names the number.
  in.p_value = 1.01e-4;
  d = lab::decide(in);
  EXPECT_EQ(d.verdict, Verdict::kNotSignificant);
  EXPECT_NEAR(d.family_p, 1.01e-3, 1e-15);
  EXPECT_NE(d.reason.find("family-wise p = 0.001"), std::string::npos) << d.reason;
  in.p_value = 0.99e-4;
  EXPECT_EQ(lab::decide(in).verdict, Verdict::kRecommended);
  // Capped at 1.
  in.p_value = 0.5;
  EXPECT_EQ(lab::decide(in).family_p, 1.0);
}

TEST(Verdict, NoStepWithoutHeldOutGainAndConstraintsRefuseWithTheirReason) {
  auto in = significantInputs();
  in.heldout_reduction = -0.02;
  auto d = lab::decide(in);
  EXPECT_EQ(d.verdict, Verdict::kNoHeldOutGain);
  EXPECT_NE(d.reason.find("does not fall"), std::string::npos) << d.reason;
  in.heldout_reduction = 0.005;
  EXPECT_EQ(lab::decide(in).verdict, Verdict::kNoHeldOutGain);
  in.heldout_reduction = 0.5;
  in.refusals.push_back({"the mass is -0.3 kg (must be > 0)", "more orientations"});
  d = lab::decide(in);
  EXPECT_EQ(d.verdict, Verdict::kRefused);
  EXPECT_NE(d.reason.find("mass is -0.3"), std::string::npos);
  EXPECT_EQ(d.separating_motion, "more orientations");
  EXPECT_STREQ(lab::verdictWord(d.verdict), "refused");
  // Significance first: a refused effect that is not significant is reported as not significant.
  in.p_value = 0.2;
  EXPECT_EQ(lab::decide(in).verdict, Verdict::kNotSignificant);
  in.added_params = 0;
  EXPECT_EQ(lab::decide(in).verdict, Verdict::kNothingToAdd);
}

/// A hand-made fit of paper+rigid_body(+cable) with a diagonal covariance.
lab::FitView view(const effects::Model& m, double sd) {
  lab::FitView f;
  f.model = &m;
  f.names = m.paramIndex().names();
  const auto n = static_cast<Eigen::Index>(f.names.size());
  f.theta = Eigen::VectorXd::Zero(n);
  f.covariance = Eigen::MatrixXd::Identity(n, n) * sd * sd;
  f.added.assign(f.names.size(), false);
  auto set = [&](const std::string& name, double v) {
    const int c = m.paramIndex().column(name);
    ASSERT_GE(c, 0) << name;
    f.theta(c) = v;
  };
  set("mass", 2.0);
  set("mass_com_z", 2.0 * 0.05);
  // I_S = I_C + m (c^T c 1 - c c^T) with I_C = diag(0.01, 0.01, 0.005), c = (0, 0, 0.05).
  set("i_s_xx", 0.01 + 2.0 * 0.0025);
  set("i_s_yy", 0.01 + 2.0 * 0.0025);
  set("i_s_zz", 0.005);
  return f;
}

int col(const lab::FitView& f, const std::string& name) {
  for (std::size_t k = 0; k < f.names.size(); ++k) {
    if (f.names[k] == name) return static_cast<int>(k);
  }
  return -1;
}

TEST(Verdict, PhysicsRefusesNegativeMassNonPhysicalInertiaAndAPushingSpring) {
  const auto m = effects::Model::fromName("paper+rigid_body+cable");
  auto f = view(m, 1e-4);
  EXPECT_TRUE(lab::physicsRefusals(f).empty());
  auto g = f;
  g.theta(col(g, "mass")) = -0.65;
  ASSERT_EQ(lab::physicsRefusals(g).size(), 1u);
  EXPECT_NE(lab::physicsRefusals(g)[0].reason.find("mass is -0.65"), std::string::npos);
  g = f;
  g.theta(col(g, "i_s_zz")) = 0.03;  // I_C zz 0.03 > xx + yy = 0.02: triangle inequality broken
  ASSERT_EQ(lab::physicsRefusals(g).size(), 1u);
  EXPECT_NE(lab::physicsRefusals(g)[0].reason.find("inertia"), std::string::npos);
  // ... but not beyond its uncertainty: accepted.
  auto h = view(m, 0.01);
  h.theta(col(h, "i_s_zz")) = 0.021;
  h.theta(col(h, "cable_k")) = 0.0;
  EXPECT_TRUE(lab::physicsRefusals(h).empty());
  g = f;
  g.theta(col(g, "cable_k")) = -0.79;
  ASSERT_EQ(lab::physicsRefusals(g).size(), 1u);
  EXPECT_NE(lab::physicsRefusals(g)[0].reason.find("spring constant is -0.79"), std::string::npos);
  g.covariance(col(g, "cable_k"), col(g, "cable_k")) = 0.5 * 0.5;  // -0.79 +- 0.5: not beyond 2 se
  EXPECT_TRUE(lab::physicsRefusals(g).empty());
}

// writeRefusal is identify's writing rule on the lab's fit: a possible inertia is written; an
// impossible one within 3 standard errors is written projected when its standard errors are at most
// a third of the tensor's scale (its largest |eigenvalue|), and refused, with identify's reason,
// when they are not (the data do not determine it); models without rigid_body have no inertia to refuse.
TEST(Verdict, WriteRefusalFollowsIdentifysProjectionRule) {
  const auto m = effects::Model::fromName("paper+rigid_body+cable");
  EXPECT_EQ(lab::writeRefusal(view(m, 1e-4)), "");
  // I_C zz 0.0205 > xx + yy = 0.02: the triangle inequality broken by 0.0005, within the errors.
  auto h = view(m, 0.001);  // +- 0.001, a twentieth of the tensor's scale (0.0205): projected
  h.theta(col(h, "i_s_zz")) = 0.0205;
  EXPECT_TRUE(lab::physicsRefusals(h).empty());
  EXPECT_EQ(lab::writeRefusal(h), "");
  auto u = view(m, 0.01);  // +- 0.01, half the scale: not a measurement of the tensor, refused
  u.theta(col(u, "i_s_zz")) = 0.0205;
  EXPECT_TRUE(lab::physicsRefusals(u).empty());
  const std::string why = lab::writeRefusal(u);
  EXPECT_NE(why.find("triangle inequality"), std::string::npos) << why;
  EXPECT_NE(why.find("do not determine the inertia"), std::string::npos) << why;
  // Any model with a mass: identify refuses a mass the data do not determine (its standard error
  // above a third of it), as the verdict's physics, possible within 3 standard errors, does not.
  const auto paper = effects::Model::fromName("paper");
  lab::FitView p;
  p.model = &paper;
  p.names = paper.paramIndex().names();
  p.theta = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(p.names.size()));
  p.covariance = Eigen::MatrixXd::Identity(p.theta.size(), p.theta.size()) * 1e-4;
  p.theta(col(p, "mass")) = 0.9;  // +- 0.01
  EXPECT_EQ(lab::writeRefusal(p), "");
  p.covariance(col(p, "mass"), col(p, "mass")) = 0.4 * 0.4;  // 0.9 +- 0.4
  EXPECT_TRUE(lab::physicsRefusals(p).empty());
  EXPECT_NE(lab::writeRefusal(p).find("not determined"), std::string::npos) << lab::writeRefusal(p);
}

// A mass that moves with a signal must be positive at every sample of the fit, not only at the
// signal's reference: payload(grip) with mass 0.5 kg at grip = 0 and -0.8 kg per unit of grip is
// impossible once grip passes 0.625.
TEST(Verdict, PhysicsRefusesAMassThatTheSignalDrivesBelowZero) {
  const auto m = effects::Model::fromName("paper+payload(grip)");
  lab::FitView f;
  f.model = &m;
  for (const auto& p : m.params()) f.names.push_back(p.name);
  f.theta = Eigen::VectorXd::Zero(m.numParams());
  f.covariance = 1e-8 * Eigen::MatrixXd::Identity(m.numParams(), m.numParams());
  f.theta(col(f, "mass")) = 0.5;
  f.theta(col(f, "dmass_grip")) = -0.8;
  const std::vector<std::string> names = {"grip"};
  std::vector<double> grip(11);
  std::vector<effects::SampleContext> samples(11);
  for (std::size_t k = 0; k < samples.size(); ++k) {
    samples[k].t = 0.1 * static_cast<double>(k);
    samples[k].extra_names = &names;
  }
  auto run = [&](double grip_max) {
    for (std::size_t k = 0; k < samples.size(); ++k) {
      grip[k] = grip_max * static_cast<double>(k) / 10.0;
      samples[k].extra = &grip[k];
    }
    f.samples = &samples;
    return lab::physicsRefusals(f);
  };
  EXPECT_TRUE(run(0.6).empty());  // 0.02 kg left at grip = 0.6
  const auto r = run(1.0);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_NE(r[0].reason.find("payload(grip)"), std::string::npos) << r[0].reason;
  EXPECT_NE(r[0].reason.find("is -0.3 kg at t = 1 s"), std::string::npos) << r[0].reason;
  f.samples = nullptr;  // not checked without the samples
  EXPECT_TRUE(lab::physicsRefusals(f).empty());
}

TEST(Verdict, IdentifiabilityIsJudgedByTheRicherModelsOwnCovariance) {
  const auto m = effects::Model::fromName("paper+cable");
  auto f = lab::FitView();
  f.model = &m;
  f.names = m.paramIndex().names();
  const auto n = static_cast<Eigen::Index>(f.names.size());
  f.theta = Eigen::VectorXd::Zero(n);
  f.added.assign(f.names.size(), false);
  const int cm = col(f, "mass"), ck = col(f, "cable_ka_z");
  ASSERT_GE(cm, 0);
  ASSERT_GE(ck, 0);
  for (const char* a : {"cable_k", "cable_ka_x", "cable_ka_y", "cable_ka_z"}) f.added[static_cast<std::size_t>(col(f, a))] = true;
  f.theta(cm) = 2.2;
  f.theta(ck) = 3.0;
  // Correlation 0.995 between the mass and the cable's pull, but the mass determined to 0.5 %:
  // identifiable (the hidden-cable case; the simpler model's errors do not matter).
  f.covariance = Eigen::MatrixXd::Identity(n, n) * 1e-6;
  const double sm = 0.011, sk = 0.1;
  f.covariance(cm, cm) = sm * sm;
  f.covariance(ck, ck) = sk * sk;
  f.covariance(cm, ck) = f.covariance(ck, cm) = 0.995 * sm * sk;
  EXPECT_TRUE(lab::identifiabilityRefusals(f).empty());
  // The same correlation with the mass no longer determined (0.4 kg of 2.2): refused, named.
  const double sm2 = 0.4;
  f.covariance(cm, cm) = sm2 * sm2;
  f.covariance(cm, ck) = f.covariance(ck, cm) = 0.995 * sm2 * sk;
  const auto r = lab::identifiabilityRefusals(f);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_NE(r[0].reason.find("mass is no longer determined"), std::string::npos) << r[0].reason;
  EXPECT_NE(r[0].reason.find("cable_ka_z"), std::string::npos) << r[0].reason;
  // Two added parameters, each correlated only 0.7 with the undetermined mass (no pair reaches
  // 0.9) and not with each other, together explain 98 % of its variance (multiple correlation 0.99):
  // refused. With one of them at 0.6 and the other at 0 (multiple correlation 0.6): not the
  // candidate's doing, not refused.
  const int ck2 = col(f, "cable_ka_x");
  ASSERT_GE(ck2, 0);
  f.covariance(ck2, ck2) = sk * sk;
  f.covariance(cm, ck) = f.covariance(ck, cm) = 0.7 * sm2 * sk;
  f.covariance(cm, ck2) = f.covariance(ck2, cm) = 0.7 * sm2 * sk;
  const auto r3 = lab::identifiabilityRefusals(f);
  ASSERT_EQ(r3.size(), 1u);
  EXPECT_NE(r3[0].reason.find("mass is no longer determined"), std::string::npos) << r3[0].reason;
  EXPECT_NE(r3[0].reason.find("multiple correlation with the added parameters 0.9899"), std::string::npos) << r3[0].reason;
  f.covariance(cm, ck) = f.covariance(ck, cm) = 0.6 * sm2 * sk;
  f.covariance(cm, ck2) = f.covariance(ck2, cm) = 0.0;
  EXPECT_TRUE(lab::identifiabilityRefusals(f).empty());
  f.covariance(ck2, ck2) = 1e-6;
  // A direction the data do not determine at all (rank deficiency) mixing the two.
  f.covariance(cm, cm) = sm * sm;
  f.covariance(cm, ck) = f.covariance(ck, cm) = 0.0;
  f.null_space = Eigen::MatrixXd::Zero(n, 1);
  f.null_space(cm, 0) = std::sqrt(0.5);
  f.null_space(ck, 0) = std::sqrt(0.5);
  const auto r2 = lab::identifiabilityRefusals(f);
  ASSERT_EQ(r2.size(), 1u);
  EXPECT_NE(r2[0].reason.find("confounded"), std::string::npos) << r2[0].reason;
}

TEST(Verdict, AnglesWrapToThePrincipalRange) {
  const double pi = 3.14159265358979323846;
  EXPECT_NEAR(lab::wrapAngle(17.3), 17.3 - 6.0 * pi, 1e-12);
  EXPECT_NEAR(lab::wrapAngle(-59.8), -59.8 + 20.0 * pi, 1e-12);
  EXPECT_DOUBLE_EQ(lab::wrapAngle(pi), pi);
  EXPECT_DOUBLE_EQ(lab::wrapAngle(-pi), pi);
  EXPECT_DOUBLE_EQ(lab::wrapAngle(0.25), 0.25);
  for (double a = -50.0; a < 50.0; a += 0.37) {
    const double w = lab::wrapAngle(a);
    EXPECT_GT(w, -pi);
    EXPECT_LE(w, pi);
    EXPECT_NEAR(std::cos(w), std::cos(a), 1e-12);
    EXPECT_NEAR(std::sin(w), std::sin(a), 1e-12);
  }
}

TEST(Verdict, SuggestedWordsAreShellQuotedOnlyWhereNeeded) {
  EXPECT_EQ(lab::shellQuote("paper+rigid_body+cable"), "paper+rigid_body+cable");
  EXPECT_EQ(lab::shellQuote("run-1.csv"), "run-1.csv");
  EXPECT_EQ(lab::shellQuote("paper+rigid_body+harmonic(q6,1)"), "'paper+rigid_body+harmonic(q6,1)'");
  EXPECT_EQ(lab::shellQuote("my log.csv"), "'my log.csv'");
  EXPECT_EQ(lab::shellQuote("it's.csv"), "'it'\\''s.csv'");
  EXPECT_EQ(lab::shellQuote(""), "''");
  // The shell itself reads the quoted word back as the original.
  for (const std::string w : {"paper+harmonic(q6,1)", "a b$c", "it's;rm"}) {
    const std::string cmd = "printf %s " + lab::shellQuote(w);
    FILE* p = popen(cmd.c_str(), "r");
    ASSERT_NE(p, nullptr);
    char buf[256] = {0};
    const std::size_t got = fread(buf, 1, sizeof(buf) - 1, p);
    pclose(p);
    EXPECT_EQ(std::string(buf, got), w) << cmd;
  }
}

}  // namespace
}  // namespace ftid
