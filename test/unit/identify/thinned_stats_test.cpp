// Statistical claims on thinned logs (issue 26, docs/log-format.md "Limits"): a log beyond
// --max-rows is read with blocks of consecutive rows left out. The standard errors printed are
// those of the rows used, and the claim is that they still hold, on white and coloured noise and
// on a static pose set: over 100 seeded draws of the simulator's own noise (white or 10 Hz
// filtered), added to the whole run before the rows are chosen (as a real sensor's noise is), the estimates on the rows kept scatter as the reported
// standard errors say (seed_study.hpp: ratio within +-30 %, bias within 4 spread/sqrt(n), and
// 1.7x too large or too small standard errors rejected). The rows kept come from readLogThinned
// on the run's own file; they depend on the joint velocities only, not on the noise.
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "ftid/identify/paper_method.hpp"
#include "ftid/logio/log.hpp"
#include "paper_cell.hpp"
#include "seed_study.hpp"
#include "test_paths.hpp"

namespace ftid::identify {
namespace {

using stats_test::Estimates;
using test::Table2;

/// The indices of the run's rows that readLogThinned keeps within `max_rows`, and the log's note.
std::vector<std::size_t> keptRows(const sim::CellSimConfig& clean, std::size_t max_rows, const std::string& name,
                                  logio::ThinnedLog* thinned) {
  const logio::LogData run = sim::CellSim(clean).run();
  const std::string path = test::binaryPath("/thinned_stats_") + name + ".csv";
  logio::writeLog(path, run);
  *thinned = logio::readLogThinned(path, logio::LogKind::kMeasurement, {}, max_rows);
  std::vector<std::size_t> kept;
  std::size_t i = 0;
  for (const logio::LogSample& s : thinned->log.samples) {
    while (i < run.samples.size() && run.samples[i].t != s.t) ++i;
    if (i == run.samples.size()) throw std::logic_error("a kept row's time is not in the run");
    kept.push_back(i);
  }
  return kept;
}

/// The paper's method on the kept rows of 100 draws of the run's noise.
void expectThinnedClaims(const sim::CellSimConfig& noisy, std::size_t max_rows, const std::string& name,
                         std::uint64_t first_seed, logio::ThinnedLog* thinned,
                         PaperMethod method = PaperMethod::kDynamic) {
  sim::CellSimConfig clean = noisy;
  clean.noise = sim::NoiseConfig{};
  const std::vector<std::size_t> kept = keptRows(clean, max_rows, name, thinned);
  ASSERT_TRUE(thinned->thinned());
  PaperOptions o;
  o.method = method;
  const auto estimator = [&kept, &o](const std::vector<effects::SampleContext>& ctx) {
    std::vector<effects::SampleContext> used;
    for (std::size_t i : kept) used.push_back(ctx[i]);
    Estimates e;
    for (const auto& p : identifyPaper(used, o).params) e[p.name] = {p.value, p.std};
    return e;
  };
  const auto study = stats_test::runSeedStudy(test::contextsOf(clean).samples, stats_test::simulatorNoise(noisy),
                                              estimator, 100, first_seed);
  for (const char* p : {"mass", "com_z", "com_x", "f0_x", "t0_y", "tilt_u", "tilt_v"}) {
    stats_test::expectClaim(study, p, Table2::value(p));
  }
}

sim::CellSimConfig filtered(double duration_s, bool lowpass = true) {
  sim::CellSimConfig cfg = test::paperConfig(true, 1);
  if (lowpass) cfg.noise.wrench_lowpass_hz = 10.0;  // lag-1 correlation 0.6 at 125 Hz
  cfg.duration_s = duration_s;
  return cfg;
}

TEST(ThinnedStats, TheRestThinnedInBlocksBesideTheWholeMotion) {
  // 10 s of excitation, then 50 s holding the last pose (7501 rows); --max-rows 2600: the motion
  // whole, every 8th block of 162 rows of the rest.
  logio::ThinnedLog thinned;
  expectThinnedClaims(filtered(60.0), 2600, "rest", 31000, &thinned);
  EXPECT_EQ(thinned.moving_stride, 1u);
  EXPECT_EQ(thinned.still_stride, 8u);
}

TEST(ThinnedStats, TheMotionItselfThinnedInBlocks) {
  // The 10 s excitation alone (1251 rows); --max-rows 600: every 4th block of 37 rows of it.
  logio::ThinnedLog thinned;
  expectThinnedClaims(filtered(10.0), 600, "motion", 32000, &thinned);
  EXPECT_EQ(thinned.moving_stride, 4u);
}

TEST(ThinnedStats, TheRestThinnedInBlocksWithWhiteNoise) {
  logio::ThinnedLog thinned;
  expectThinnedClaims(filtered(60.0, false), 2600, "rest_white", 33000, &thinned);
  EXPECT_EQ(thinned.still_stride, 8u);
}

TEST(ThinnedStats, AStaticPoseSetThinnedInBlocks) {
  // 40 poses along the excitation, each held 0.25 s (31 rows, 1240 in all, every one still);
  // --max-rows 800: blocks of 50 rows, every 2nd kept (13 blocks across about 26 of the poses);
  // the paper's static method, filtered noise.
  sim::CellSimConfig cfg = filtered(10.0);
  cfg.static_poses.enabled = true;
  cfg.static_poses.poses = 40;
  cfg.static_poses.hold_s = 0.25;
  logio::ThinnedLog thinned;
  expectThinnedClaims(cfg, 800, "poses", 34000, &thinned, PaperMethod::kStatic);
  EXPECT_EQ(thinned.moving_rows, 0u);
  EXPECT_EQ(thinned.still_stride, 2u);
}

}  // namespace
}  // namespace ftid::identify
