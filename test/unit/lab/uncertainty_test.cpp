// Standard errors that hold: over many noise seeds the spread of the estimates must match the
// standard error the fit reports (within +-30 %), for white noise, low-pass filtered noise and a
// static pose set (docs/identification.md, "Standard errors"). The simulator draws the noise its
// own way (cell_sim.cpp); the fit only sees the log.
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "ftid/identify/fit.hpp"
#include "ftid/identify/uncertainty.hpp"
#include "ftid/lab/analyze.hpp"
#include "lab_sim.hpp"

namespace {

using namespace ftid;

constexpr int kSeeds = 50;

struct Spread {
  std::map<std::string, std::vector<double>> value, reported;
};

void collect(const identify::FitResult& fit, Spread& s) {
  for (const char* name : {"mass", "com_x", "f0_x", "tilt_u"}) {
    s.value[name].push_back(fit.value(name));
    s.reported[name].push_back(fit.stddev(name));
  }
}

void expectSpreadMatchesReported(const Spread& s, const std::string& label) {
  for (const auto& [name, v] : s.value) {
    double mean = 0.0;
    for (double x : v) mean += x;
    mean /= static_cast<double>(v.size());
    double ss = 0.0;
    for (double x : v) ss += (x - mean) * (x - mean);
    const double empirical = std::sqrt(ss / static_cast<double>(v.size() - 1));
    double rs = 0.0;
    for (double x : s.reported.at(name)) rs += x * x;
    const double reported = std::sqrt(rs / static_cast<double>(v.size()));
    const double ratio = empirical / reported;
    EXPECT_GT(ratio, 0.7) << label << " " << name << ": spread " << empirical << ", reported " << reported;
    EXPECT_LT(ratio, 1.3) << label << " " << name << ": spread " << empirical << ", reported " << reported;
    std::printf("%-10s %-7s spread %.4g  reported %.4g  ratio %.3f\n", label.c_str(), name.c_str(), empirical, reported,
                ratio);
  }
}

Spread run(const std::function<void(sim::CellSimConfig&)>& setup) {
  Spread s;
  const effects::Model model = effects::Model::fromName("paper");
  for (int k = 0; k < kSeeds; ++k) {
    sim::CellSimConfig c = labtest::baseConfig(1000 + static_cast<std::uint64_t>(k));
    setup(c);
    const samples::ContextSet set = labtest::contexts(c);
    collect(identify::fitModel(model, set.samples), s);
  }
  return s;
}

TEST(StandardErrors, MatchTheSpreadOverSeedsForWhiteNoise) {
  expectSpreadMatchesReported(run([](sim::CellSimConfig&) {}), "white");
}

TEST(StandardErrors, MatchTheSpreadOverSeedsForLowPassFilteredNoise) {
  // A 1st-order 10 Hz filter at 125 Hz: lag-1 correlation 0.6, the classical standard errors are
  // about half the true spread.
  expectSpreadMatchesReported(run([](sim::CellSimConfig& c) { c.noise.wrench_lowpass_hz = 10.0; }), "filtered");
}

TEST(StandardErrors, MatchTheSpreadOverSeedsForAStaticPoseSet) {
  // 40 poses held 0.25 s each (31 readings a pose), filtered noise within the holds.
  expectSpreadMatchesReported(run([](sim::CellSimConfig& c) {
                                c.noise.wrench_lowpass_hz = 10.0;
                                c.static_poses.enabled = true;
                                c.static_poses.poses = 40;
                                c.static_poses.hold_s = 0.25;
                              }),
                              "static");
}

TEST(StandardErrors, RobustCovarianceEqualsClassicalForWhiteResidualsAtLagZero) {
  // Independent check of the sandwich: with L = 0 and one parameter per axis (a constant), the
  // covariance is sum(r^2 J^2) / (J^T J)^2 scaled by 6n/(6n - k).
  const int n = 200;
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(6 * n, 1);
  Eigen::VectorXd r(6 * n);
  for (int i = 0; i < 6 * n; ++i) {
    J(i, 0) = 1.0 + 0.01 * (i % 7);
    r(i) = std::sin(0.37 * i);
  }
  const Eigen::MatrixXd G = J.transpose() * J;
  const auto rep = identify::robustCovariance(J, r, G.inverse(), 0);
  double num = 0.0;
  for (int i = 0; i < n; ++i) {
    double s = 0.0;
    for (int a = 0; a < 6; ++a) s += J(6 * i + a, 0) * r(6 * i + a);
    num += s * s;
  }
  const double expect = (6.0 * n / (6.0 * n - 1.0)) * num / (G(0, 0) * G(0, 0));
  EXPECT_NEAR(rep.covariance(0, 0), expect, 1e-12 * expect);
  EXPECT_THROW(identify::robustCovariance(J.topRows(5), r.head(5), G.inverse()), std::invalid_argument);
}

}  // namespace

namespace {

// The laboratory's own standard errors (prewhitened fits, docs/analyze.md) on filtered noise.
TEST(StandardErrors, LaboratoryMatchesTheSpreadOverSeedsForLowPassFilteredNoise) {
  std::map<std::string, std::vector<double>> value, reported;
  for (int k = 0; k < kSeeds; ++k) {
    sim::CellSimConfig c = labtest::baseConfig(3000 + static_cast<std::uint64_t>(k));
    c.noise.wrench_lowpass_hz = 10.0;
    const samples::ContextSet set = labtest::contexts(c);
    lab::AnalyzeOptions o;
    o.candidates = {"poly(t,2)"};
    const lab::AnalysisResult r = lab::analyze(set.samples, nullptr, o, "sim.csv");
    for (const char* name : {"mass", "com_x", "f0_x", "tilt_u"}) {
      const auto* p = labtest::findParam(r.report, name);
      ASSERT_NE(p, nullptr) << name;
      value[name].push_back(p->value);
      reported[name].push_back(p->std);
    }
  }
  Spread s;
  s.value = value;
  s.reported = reported;
  expectSpreadMatchesReported(s, "lab");
}

}  // namespace
