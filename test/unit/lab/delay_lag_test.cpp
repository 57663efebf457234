// A compliant mount lags the reading by about 2 zeta / w_n, which `--explain` takes first as a
// sensor_delay. The laboratory then asks whether that delay is the mount's lag: with the IMU's
// stream delay (payload-free), the model with its delay held there and the filter searched again
// is judged against the delay set free, by the one rule (detail::judgeDelayAgainstLag,
// docs/effects.md "Dynamics of the reading"). Simulator logs as `ftid simulate` writes them: the
// paper's 10 s motion, a 3 kg tool, a MEMS-grade IMU with biases, read through `ftid analyze`'s
// file path with --explain. The mount is the simulator's own (RK4 inside each sample), not ftid's
// Tustin filter.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "ftid/lab/analyze.hpp"
#include "ftid/lab/dynamics.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/samples/context.hpp"
#include "ftid/sim/cell_sim.hpp"
#include "ftid/sim/effect_spec.hpp"
#include "lab_sim.hpp"
#include "test_paths.hpp"

namespace ftid {
namespace {

using lab::AnalysisResult;

/// `ftid simulate --mass 3 --noise-acc 0.01 --noise-gyro 0.002 --effect E...` (imu_noise false:
/// the command's default, a noise-free IMU).
sim::CellSimConfig cellWith(std::uint64_t seed, const std::vector<std::string>& effects, bool imu_noise = true) {
  sim::CellSimConfig c = sim::paperCellConfig(labtest::robot());
  c.seed = seed;
  c.payload.mass_kg = 3.0;
  c.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  c.noise.acc_std = imu_noise ? 0.01 : 0.0;
  c.noise.gyro_std = imu_noise ? 0.002 : 0.0;
  for (const auto& e : effects) sim::applyEffectSpec(e, c);
  return c;
}

/// The log written and analysed with --explain, as `ftid analyze LOG --explain`.
AnalysisResult analyzeLog(const sim::CellSimConfig& c, const std::string& name) {
  const std::string dir = ::testing::TempDir() + "delay_lag_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const std::string log = dir + "/" + name + ".csv";
  logio::writeLog(log, sim::CellSim(c).run());
  lab::AnalyzeFilesRequest req;
  req.log_path = log;
  req.robot_urdf = ftid::test::sourcePath("/config/ur10.urdf");
  req.options.explain = true;
  AnalysisResult r = lab::analyzeRecordings(req);
  std::filesystem::remove(log);
  return r;
}

const identify::ImuComparison* delayComparison(const AnalysisResult& r) {
  for (const auto& c : r.imu.comparisons) {
    if (c.quantity == "delay") return &c;
  }
  return nullptr;
}

bool warnsOnTheDelay(const AnalysisResult& r) {
  for (const auto& w : r.warnings) {
    if (w.find("disagree on the delay") != std::string::npos) return true;
  }
  return false;
}

/// The path took a sensor_delay and the mount was found: the case this judgement is for.
void expectLagJudged(const AnalysisResult& r) {
  ASSERT_TRUE(r.final_report.has_value());
  ASSERT_NE(r.final_report->model.find("sensor_delay"), std::string::npos) << r.final_report->model;
  ASSERT_TRUE(r.dynamics.significant) << lab::dynamicsLine(r.dynamics, r.noise_floor);
  ASSERT_TRUE(r.dynamics.delay.tested);
  std::printf("  %s\n", lab::delayAgainstLagLine(r.dynamics).c_str());
}

// 6 Hz, zeta 0.05 (lag 2.65 ms), no stream delay: the model's delay is the lag, the IMU agrees.
// Before: "DISAGREE delay: IMU stream -0.04 ms, given 2.62 ms" and a set-up-error warning. Seed 9
// with the command's noise-free IMU: its delay 1e-13 ms leaves the first sample active where the
// free delay's (0.06 ms) does not; compared on different samples, that one sample's gain alone
// made the rule take a delay of 0.06 ms (family-wise p = 0.0007). 4 Hz, zeta 0.2 (lag 15.9 ms),
// seed 11: the search for the filter in turns of f_n and zeta crawled along their ridge of
// constant lag and stopped at 3.22 Hz, 0.16, and the rule took a delay (p = 3e-114).
TEST(DelayAgainstLag, ACompliantMountsLagIsNotAStreamDelay) {
  struct Case {
    std::uint64_t seed;
    bool imu_noise;
    double f_hz, zeta;
  };
  for (const Case& k : {Case{4, true, 6.0, 0.05}, Case{9, false, 6.0, 0.05}, Case{11, true, 4.0, 0.2}}) {
    SCOPED_TRACE("seed " + std::to_string(k.seed));
    const std::string mount = "mount_dynamics:f=" + std::to_string(k.f_hz) + ",zeta=" + std::to_string(k.zeta);
    const AnalysisResult r = analyzeLog(cellWith(k.seed, {"imu", mount}, k.imu_noise), "mount");
    expectLagJudged(r);
    const auto& g = r.dynamics.delay;
    EXPECT_TRUE(g.imu_compared);
    EXPECT_TRUE(g.delay_is_lag) << g.reason;
    EXPECT_NEAR(g.held_f_hz, k.f_hz, 0.1 * k.f_hz);
    EXPECT_NEAR(g.held_zeta, k.zeta, 0.4 * k.zeta);
    EXPECT_NEAR(g.model_delay_s, g.imu_delay_s + g.held_lag_s, 0.1 * g.model_delay_s);
    const identify::ImuComparison* c = delayComparison(r);
    ASSERT_NE(c, nullptr);
    EXPECT_FALSE(c->disagrees) << c->message;
    EXPECT_FALSE(warnsOnTheDelay(r));
    const std::string line = lab::delayAgainstLagLine(r.dynamics);
    EXPECT_NE(line.find("consistent with the IMU's stream delay plus the reading's lag"), std::string::npos);
    // The rule's own reason is printed, so no p-value stands beside "does not take" unexplained.
    EXPECT_FALSE(g.reason.empty());
    EXPECT_NE(line.find("does not take a different delay (" + g.reason + ")"), std::string::npos) << line;
  }
}

// The same mount behind an 8 ms stream delay the IMU shares: the lag is separated from the delay.
TEST(DelayAgainstLag, AStreamDelayTheImuSharesIsSeparatedFromTheLag) {
  const AnalysisResult r =
      analyzeLog(cellWith(5, {"imu:delay=0.008", "sensor_delay:tau=0.008", "mount_dynamics:f=6,zeta=0.05"}), "shared");
  expectLagJudged(r);
  const auto& g = r.dynamics.delay;
  EXPECT_TRUE(g.delay_is_lag) << g.reason;
  EXPECT_NEAR(g.imu_delay_s, 0.008, 0.5e-3);
  EXPECT_NEAR(g.model_delay_s, 0.008 + 2.0 * 0.05 / (2.0 * M_PI * 6.0), 0.7e-3);
  EXPECT_FALSE(warnsOnTheDelay(r));
}

// A 30 ms delay of the wrench alone (a filter in the sensor's wrench path, or a set-up error) is
// more than any filter that keeps the 6 Hz ringing can lag: the rule takes it and the IMU disagrees.
TEST(DelayAgainstLag, AWrenchOnlyDelayBeyondTheLagIsASetUpError) {
  const AnalysisResult r =
      analyzeLog(cellWith(14, {"imu", "sensor_delay:tau=0.03", "mount_dynamics:f=6,zeta=0.05"}), "beyond");
  expectLagJudged(r);
  const auto& g = r.dynamics.delay;
  EXPECT_TRUE(g.imu_compared);
  EXPECT_FALSE(g.delay_is_lag);
  EXPECT_LT(g.family_p, 1e-3);
  EXPECT_NEAR(g.delay_s, 0.03, 3e-3);
  const identify::ImuComparison* c = delayComparison(r);
  ASSERT_NE(c, nullptr);
  EXPECT_TRUE(c->disagrees) << c->message;
  EXPECT_TRUE(warnsOnTheDelay(r));
}

// An 8 Hz, zeta 0.1 mount beside a temperature drift (`ftid simulate --mass 3 --seed 43 --effect
// temperature_drift --noise-temp 0.05 --effect mount_dynamics:f=8,zeta=0.1`): against `paper`
// rigid_body is refused (its inertia is impossible while the lag is unmodelled), no single effect
// beats two offsets steps (15.6 % of the held-out error, at 3.88 s and 4.80 s), and the dynamics
// found on `paper` (6.1 %) did not either: the log was reported as three set-ups. The smooth model
// --explain reaches (83 %) competes with the steps now, and the path runs.
TEST(DelayAgainstLag, ALagBesideATemperatureDriftIsNoChangeInTime) {
  sim::CellSimConfig c = cellWith(43, {"imu", "temperature_drift", "mount_dynamics:f=8,zeta=0.1"});
  c.noise.temp_std = 0.05;
  const AnalysisResult r = analyzeLog(c, "drift_mount");
  EXPECT_TRUE(r.change_points.empty()) << lab::formatText(r);
  ASSERT_TRUE(r.final_report.has_value());
  for (const char* e : {"rigid_body", "temperature_drift", "sensor_delay"}) {
    EXPECT_NE(r.final_report->model.find(e), std::string::npos) << e << " in " << r.final_report->model;
  }
  for (const auto& w : r.warnings) EXPECT_EQ(w.find("set-ups"), std::string::npos) << w;
  EXPECT_TRUE(r.dynamics.significant);
}

// Without the IMU columns the trade-off is said, and no verdict on the delay is given.
TEST(DelayAgainstLag, WithoutAnImuTheTradeOffIsSaid) {
  const sim::CellSimConfig c = cellWith(4, {"mount_dynamics:f=6,zeta=0.05"});
  auto ctx = samples::buildContexts(sim::CellSim(c).run(), *c.robot, {c.R_FS, c.p_FS_F, 0.0, 0.0}).samples;
  for (auto& s : ctx) s.has_imu = false;
  lab::AnalyzeOptions o;
  o.explain = true;
  const AnalysisResult r = lab::analyze(ctx, nullptr, o, "mount_no_imu.csv");
  expectLagJudged(r);
  EXPECT_FALSE(r.dynamics.delay.imu_compared);
  EXPECT_FALSE(r.imu.used);
  EXPECT_NE(lab::delayAgainstLagLine(r.dynamics).find("without an IMU a delay and a filter's lag trade off"),
            std::string::npos);
}

}  // namespace
}  // namespace ftid
