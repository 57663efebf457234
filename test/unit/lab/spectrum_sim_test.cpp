// The residual's spectrum inside `ftid analyze` (issue 22, sensor and mount dynamics) on simulator
// runs, the laboratory not told what is hidden:
//  - a compliant mount: the simulator's noise-free wrench at 1 kHz passed through a 2nd-order
//    response (3 Hz, damping 0.1: y'' + 2 zeta w y' + w^2 y = w^2 u) integrated here by RK4,
//    sampled at 125 Hz, white noise added: the spectrum of the residual shows a significant peak
//    at 3 Hz (within half its resolution), beyond the motion band, and the text, JSON and HTML
//    show it; the dynamics search (ftid/lab/dynamics.hpp) names mount_dynamics with f_n within
//    10 % and the held-out residual within 1.3x the noise floor, from `paper` and from
//    `paper+sensor_delay`; a 1st-order filter at 4 Hz is named sensor_filter likewise;
//  - clean runs (white noise, the simulator's own low-pass filtered noise, a static pose set),
//    50 seeds each: no axis shows a significant peak and no dynamics are found.
// Each seed is one analysis (a single cheap candidate, the spectrum does not depend on the
// ranking): seconds at -O2, labelled slow (the -O0 sanitizer build skips it).
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "../identify/seed_study.hpp"
#include "ftid/lab/analyze.hpp"
#include "lab_sim.hpp"

namespace ftid::lab {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// y'' + 2 zeta w y' + w^2 y = w^2 u on each wrench channel of `fine` (uniformly sampled), RK4 with
/// u interpolated linearly inside a step, starting at rest (y = u(0), y' = 0).
void mountResponse(logio::LogData& fine, double f_hz, double zeta) {
  const double w = 2.0 * kPi * f_hz;
  const double h = fine.samples[1].t - fine.samples[0].t;
  for (int a = 0; a < 6; ++a) {
    std::vector<double> u;
    for (const auto& s : fine.samples) u.push_back(s.wrench_S(a));
    double y = u[0], v = 0.0;
    auto acc = [&](double yy, double vv, double uu) { return w * w * (uu - yy) - 2.0 * zeta * w * vv; };
    for (std::size_t i = 0; i + 1 < u.size(); ++i) {
      fine.samples[i].wrench_S(a) = y;
      const double u0 = u[i], um = 0.5 * (u[i] + u[i + 1]), u1 = u[i + 1];
      const double k1y = v, k1v = acc(y, v, u0);
      const double k2y = v + 0.5 * h * k1v, k2v = acc(y + 0.5 * h * k1y, v + 0.5 * h * k1v, um);
      const double k3y = v + 0.5 * h * k2v, k3v = acc(y + 0.5 * h * k2y, v + 0.5 * h * k2v, um);
      const double k4y = v + h * k3v, k4v = acc(y + h * k3y, v + h * k3v, u1);
      y += h / 6.0 * (k1y + 2.0 * k2y + 2.0 * k3y + k4y);
      v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
    }
    fine.samples.back().wrench_S(a) = y;
  }
}

/// y' = w_c (u - y) on each wrench channel, RK4 with u interpolated linearly, from y = u(0).
void filterResponse(logio::LogData& fine, double fc_hz) {
  const double w = 2.0 * kPi * fc_hz;
  const double h = fine.samples[1].t - fine.samples[0].t;
  for (int a = 0; a < 6; ++a) {
    std::vector<double> u;
    for (const auto& s : fine.samples) u.push_back(s.wrench_S(a));
    double y = u[0];
    for (std::size_t i = 0; i + 1 < u.size(); ++i) {
      fine.samples[i].wrench_S(a) = y;
      const double um = 0.5 * (u[i] + u[i + 1]);
      const double k1 = w * (u[i] - y), k2 = w * (um - (y + 0.5 * h * k1)), k3 = w * (um - (y + 0.5 * h * k2)),
                   k4 = w * (u[i + 1] - (y + h * k3));
      y += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    }
    fine.samples.back().wrench_S(a) = y;
  }
}

/// A 10 s run seen through a compliant mount (f_hz, zeta > 0) or a sensor filter (cut-off f_hz,
/// zeta = 0), computed at 1 kHz and sampled at 125 Hz, white noise of baseConfig.
std::vector<SampleContext> mountRun(double f_hz, double zeta, std::uint64_t seed) {
  sim::CellSimConfig c = labtest::baseConfig(seed);
  c.noise = sim::NoiseConfig{};
  c.rate_hz = 1000.0;
  logio::LogData fine = sim::CellSim(c).run();
  if (zeta > 0.0) {
    mountResponse(fine, f_hz, zeta);
  } else {
    filterResponse(fine, f_hz);
  }
  logio::LogData log = fine;
  log.samples.clear();
  for (std::size_t i = 0; i < fine.samples.size(); i += 8) log.samples.push_back(fine.samples[i]);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  const Vec6 sd = labtest::baseConfig(seed).noise.wrench_std;
  for (auto& s : log.samples) {
    for (int a = 0; a < 6; ++a) s.wrench_S(a) += sd(a) * n01(rng);
  }
  return samples::buildContexts(log, *c.robot, {c.R_FS, c.p_FS_F, 0.0, 0.0}).samples;
}

AnalyzeOptions cheapOptions() {
  AnalyzeOptions o;
  o.model = "paper";
  o.candidates = {"time_drift"};  // the spectrum does not depend on the ranking
  return o;
}

void expectResonanceShown(const std::string& model) {
  SCOPED_TRACE(model);
  const auto ctx = mountRun(3.0, 0.1, 31);
  AnalyzeOptions o = cheapOptions();
  o.model = model;
  const AnalysisResult r = analyze(ctx, nullptr, o, "mount.csv");
  ASSERT_TRUE(r.spectrum.valid) << r.spectrum.note;
  const double df = r.spectrum.f_hz[1];
  const double f_ring = 3.0 * std::sqrt(1.0 - 0.1 * 0.1);  // the damped resonance
  int found = 0;
  for (int a = 0; a < 6; ++a) {
    const auto& ax = r.spectrum.axes[static_cast<std::size_t>(a)];
    std::printf("  %s\n", spectrumLine(r.spectrum, a).c_str());
    if (!ax.beyond.significant) continue;
    ++found;
    EXPECT_NEAR(ax.beyond.f_hz, f_ring, 0.5 * df + 1e-9) << kWrenchAxisNames[a];
  }
  EXPECT_GE(found, 3);
  EXPECT_LT(r.spectrum.motion_band_hz, f_ring - df);
  // Shown where people look: the text line, the JSON object, the HTML plot.
  EXPECT_NE(formatText(r).find("beyond the band: peak 2.93 Hz"), std::string::npos) << formatText(r);
  const auto j = nlohmann::json::parse(formatJson(r));
  // The dynamics search names the mount: f_n within 10 %, the residual within 1.3x the noise.
  std::printf("  %s\n", dynamicsLine(r.dynamics, r.noise_floor).c_str());
  EXPECT_TRUE(r.dynamics.significant);
  EXPECT_EQ(r.dynamics.effect, "mount_dynamics");
  EXPECT_NEAR(r.dynamics.f_hz, 3.0, 0.3);
  EXPECT_NEAR(r.dynamics.zeta, 0.1, 0.03);
  for (int a = 0; a < 6; ++a) EXPECT_LT(r.dynamics.residual_rms(a), 1.3 * r.noise_floor(a)) << kWrenchAxisNames[a];
  EXPECT_TRUE(j.at("dynamics").at("significant").get<bool>());
  bool warned = false;
  for (const auto& w : r.warnings) warned = warned || w.find("a compliant mount") != std::string::npos;
  EXPECT_TRUE(warned);
  bool json_peak = false;
  for (const char* axis : kWrenchAxisNames) {
    const auto& e = j.at("spectrum").at(axis);
    EXPECT_EQ(e.at("f_hz").size(), e.at("psd").size());
    EXPECT_EQ(e.at("f_hz").size(), e.at("noise_psd").size());
    json_peak = json_peak || e.at("beyond_band_peak").at("significant").get<bool>();
  }
  EXPECT_TRUE(json_peak);
  EXPECT_EQ(j.at("autocorrelation").at("fz").at("r").at(0).get<double>(), 1.0);
  EXPECT_NE(renderHtml(r).find("Spectrum of the held-out residual"), std::string::npos);
}

// The simulator's own compliant mount (`ftid simulate --effect mount_dynamics:f=3,zeta=0.1`: RK4 in
// 16 steps per 125 Hz sample inside the simulator, not the 1 kHz integration above) is found by the
// search as well: what a user reproducing the case from the command line sees.
TEST(SpectrumSim, TheSimulatorsMountSwitchIsFoundWithItsFrequencyAndDamping) {
  sim::CellSimConfig c = labtest::baseConfig(32);
  c.mount_dynamics.enabled = true;
  const auto ctx = samples::buildContexts(sim::CellSim(c).run(), *c.robot, {c.R_FS, c.p_FS_F, 0.0, 0.0}).samples;
  const AnalysisResult r = analyze(ctx, nullptr, cheapOptions(), "mount.csv");
  EXPECT_TRUE(r.dynamics.significant) << dynamicsLine(r.dynamics, r.noise_floor);
  EXPECT_EQ(r.dynamics.effect, "mount_dynamics");
  EXPECT_NEAR(r.dynamics.f_hz, 3.0, 0.3);
  EXPECT_NEAR(r.dynamics.zeta, 0.1, 0.03);
  for (int a = 0; a < 6; ++a) EXPECT_LT(r.dynamics.residual_rms(a), 1.3 * r.noise_floor(a)) << kWrenchAxisNames[a];
}

// The same switch on the command line's cell (`ftid simulate --seed N --effect mount_dynamics`: the
// paper's payload and 10 s excitation, the command's noise) and `ftid analyze LOG --explain`, through
// the log file: the mount's lag in this slow motion also reads as offsets steps of 0.1-0.16 N and
// back (held-out gain 25 % on seed 26), and before the steps had to beat the reading's dynamics
// (31 % there) every one of seeds 1-6 was reported as "three set-ups" and the path never ran.
TEST(SpectrumSim, TheCommandLinesCompliantMountIsNoChangeInTime) {
  const std::string dir = ::testing::TempDir() + "mount_cli_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  for (const std::uint64_t seed : {1u, 2u, 3u}) {
    const AnalysisResult r =
        labtest::analyzeCommandLineRun(dir + "/mount_" + std::to_string(seed) + ".csv", seed, "mount_dynamics", true);
    for (const auto& cp : r.change_points) ADD_FAILURE() << "seed " << seed << ": " << describeChangePoint(cp);
    EXPECT_TRUE(r.dynamics.significant) << "seed " << seed << ": " << dynamicsLine(r.dynamics, r.noise_floor);
    EXPECT_EQ(r.dynamics.effect, "mount_dynamics") << "seed " << seed;
    EXPECT_NEAR(r.dynamics.f_hz, 3.0, 0.3) << "seed " << seed;
  }
  if (!HasFailure()) std::filesystem::remove_all(dir);
}

// Pushes on the tool (`ftid simulate --seed 41 --effect pushes:force=8`: sin^2 pushes of 0.4-0.6 s)
// put a peak beyond the motion band (2.93 Hz, up to 1,300x the noise) that no filter of the reading
// explains (the search: "nothing of the kind"). The spectrum's warning used to say all the same that
// "the reading has dynamics of its own, a resonance ... or the sensor's filter": two findings that
// contradicted each other. It now names a disturbance of its own.
TEST(SpectrumSim, APeakNoFilterExplainsIsNotCalledTheReadingsDynamics) {
  const std::string dir = ::testing::TempDir() + "pushes_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const AnalysisResult r = labtest::analyzeCommandLineRun(dir + "/pushes.csv", 41, "pushes:force=8", true);
  ASSERT_TRUE(r.dynamics.tested);
  EXPECT_FALSE(r.dynamics.significant) << dynamicsLine(r.dynamics, r.noise_floor);
  bool peak = false;
  for (const auto& w : r.warnings) {
    if (w.find("peak beyond the motion band") == std::string::npos) continue;
    peak = true;
    EXPECT_EQ(w.find("the reading has dynamics of its own"), std::string::npos) << w;
    EXPECT_NE(w.find("no filter of the reading explains it"), std::string::npos) << w;
  }
  EXPECT_TRUE(peak);
  if (!HasFailure()) std::filesystem::remove_all(dir);
}

// Without --explain the spectrum is the starting model's. On `ftid simulate --duration 200` (the
// paper's 10 s motion, then the arm at rest; full rigid-body physics) analysed from `paper`, the
// missing effect is rigid_body, and the residual's peak beyond the motion band (0.61 Hz, 11x on fy:
// the inertia terms' products of the motion's frequencies) was called "a disturbance of its own,
// e.g. contacts or pushes", contradicting the verdict. It now names the missing effect, and so does
// the IMU's disagreement with paper's tilt (chi2 40), which rigid_body's terms pull.
TEST(SpectrumSim, APeakOfTheStartingModelIsFirstTheMissingEffects) {
  sim::CellSimConfig c = sim::paperCellConfig(labtest::robot());
  c.full_rigid_body = true;
  c.duration_s = 200.0;
  c.seed = 2;
  c.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  c.imu.enabled = true;
  c.noise.acc_std = 0.01;
  c.noise.gyro_std = 0.002;
  const AnalysisResult r = labtest::analyzeRun(c, "paper", false);
  ASSERT_FALSE(r.candidates.empty());
  ASSERT_TRUE(r.candidates.front().significant);
  EXPECT_EQ(r.candidates.front().effect, "rigid_body");
  bool peak = false;
  for (const auto& w : r.warnings) {
    if (w.find("peak beyond the motion band") == std::string::npos) continue;
    peak = true;
    EXPECT_EQ(w.find("disturbance of its own"), std::string::npos) << w;
    EXPECT_NE(w.find("the model lacks rigid_body"), std::string::npos) << w;
  }
  EXPECT_TRUE(peak);
  bool imu = false;
  for (const auto& w : r.warnings) {
    if (w.find("the IMU and paper disagree on the tilt") == std::string::npos) continue;
    imu = true;
    EXPECT_NE(w.find("first paper lacks rigid_body"), std::string::npos) << w;
  }
  EXPECT_TRUE(imu);
}

TEST(SpectrumSim, SensorFilterIsNamedWithItsCutOff) {
  // A 1st-order filter at 4 Hz: no peak (nothing rings), but the search names it.
  const AnalysisResult r = analyze(mountRun(4.0, 0.0, 32), nullptr, cheapOptions(), "filter.csv");
  std::printf("  %s\n", dynamicsLine(r.dynamics, r.noise_floor).c_str());
  EXPECT_TRUE(r.dynamics.significant);
  EXPECT_EQ(r.dynamics.effect, "sensor_filter");
  EXPECT_NEAR(r.dynamics.f_hz, 4.0, 0.4);
  for (int a = 0; a < 6; ++a) EXPECT_LT(r.dynamics.residual_rms(a), 1.3 * r.noise_floor(a)) << kWrenchAxisNames[a];
}

TEST(SpectrumSim, CompliantMountShowsTheResonance) {
  expectResonanceShown("paper");
  expectResonanceShown("paper+sensor_delay");  // where the issue's --explain ended
}

/// Significant peaks (any axis) and dynamics found over `seeds` noise draws of a clean run (the
/// paper model is exact).
int falseAlarms(const sim::CellSimConfig& noisy, std::uint64_t first_seed, int seeds) {
  sim::CellSimConfig clean = noisy;
  clean.noise = sim::NoiseConfig{};
  const std::vector<SampleContext> ctx0 = labtest::contexts(clean).samples;
  const auto noise = stats_test::simulatorNoise(noisy);
  int alarms = 0;
  for (int k = 0; k < seeds; ++k) {
    std::vector<SampleContext> ctx = ctx0;
    std::mt19937_64 rng(first_seed + static_cast<std::uint64_t>(k));
    noise(ctx, rng);
    AnalyzeOptions o = cheapOptions();
    o.always_search_dynamics = true;  // the search's own false-alarm rate (by default it would not run here)
    const AnalysisResult r = analyze(ctx, nullptr, o, "sim.csv");
    EXPECT_TRUE(r.spectrum.valid) << r.spectrum.note;
    for (const auto& w : r.warnings) EXPECT_EQ(w.find("beyond the motion band"), std::string::npos) << w;
    if (r.dynamics.significant) {
      ++alarms;
      std::printf("  seed %d: %s\n", k, dynamicsLine(r.dynamics, r.noise_floor).c_str());
    }
    for (int a = 0; a < 6; ++a) {
      if (r.spectrum.axes[static_cast<std::size_t>(a)].peak.significant) {
        ++alarms;
        std::printf("  seed %d: %s\n", k, spectrumLine(r.spectrum, a).c_str());
      }
    }
  }
  return alarms;
}

TEST(SpectrumSim, DynamicsAreSearchedOnlyWhenSomethingIsLeft) {
  const AnalysisResult r = analyze(labtest::contexts(labtest::baseConfig(7)).samples, nullptr, cheapOptions(), "sim.csv");
  EXPECT_FALSE(r.dynamics.tested);
  EXPECT_NE(r.dynamics.note.find("within 1.2x the noise floor"), std::string::npos) << r.dynamics.note;
}

TEST(SpectrumSim, NoPeakNoDynamicsOnCleanWhiteRuns) { EXPECT_EQ(falseAlarms(labtest::baseConfig(1), 41000, 50), 0); }

TEST(SpectrumSim, NoPeakNoDynamicsOnCleanFilteredRuns) {
  sim::CellSimConfig cfg = labtest::baseConfig(1);
  cfg.noise.wrench_lowpass_hz = 10.0;
  EXPECT_EQ(falseAlarms(cfg, 42000, 50), 0);
}

TEST(SpectrumSim, NoPeakNoDynamicsOnCleanStaticPoseSets) {
  sim::CellSimConfig cfg = labtest::baseConfig(1);
  cfg.static_poses.enabled = true;
  cfg.static_poses.poses = 40;
  cfg.static_poses.hold_s = 0.25;
  EXPECT_EQ(falseAlarms(cfg, 43000, 50), 0);
}

}  // namespace
}  // namespace ftid::lab
