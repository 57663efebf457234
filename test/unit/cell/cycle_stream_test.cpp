// Issue 14: identification must not be poisoned by a second publisher on FTID_CYCLE.
// Genuine stream: the paper cell simulator (independent physics, 125 Hz, noisy, seeded) turned
// into ftidd's cycle records. Attack (as found in the issue): every record republished 1 ms later
// (robot time + 1 ms, same cycle number) with fz + 5 N.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "../identify/paper_cell.hpp"
#include "ftid/cell/cycle_recorder.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/samples/context.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/identify/fit_parameters.hpp"

namespace {

using ftid::CycleRecord;

std::vector<CycleRecord> genuineStream(std::uint64_t seed) {
  ftid::sim::CellSimConfig cfg = ftid::test::paperConfig(true, seed);
  cfg.rate_hz = 125.0;
  const ftid::logio::LogData log = ftid::sim::CellSim(cfg).run();
  std::vector<CycleRecord> out;
  std::int64_t cycle = 5000;  // ftidd had been running for a while
  for (const auto& s : log.samples) {
    CycleRecord r;
    r.cycle = cycle++;
    r.utime = 1700000000000000 + static_cast<std::int64_t>(std::llround(s.t * 1e6));
    r.robot.robot_time = 1234.5 + s.t;
    r.robot.recv_utime = r.utime;
    r.robot.q = s.q;
    r.robot.qd = s.qd;
    r.robot.qdd = s.qdd;
    r.robot.valid = true;
    r.sensor.recv_utime = r.utime - 300;
    r.sensor.counter = static_cast<std::int32_t>(r.cycle % 256);
    r.sensor.wrench_S = s.wrench_S;
    r.sensor.valid = true;
    out.push_back(r);
  }
  return out;
}

double fittedF0z(const std::vector<CycleRecord>& records) {
  const ftid::logio::LogData log = ftid::cell::recordsToLog(records, -1e300, 1e300, "mem");
  const auto kin = ftid::test::ur10();
  const ftid::samples::ContextSet ctx = ftid::samples::buildContexts(log, kin);
  const auto fit = ftid::identify::fitModel(ftid::effects::Model::fromName("paper"), ctx.samples);
  for (const auto& p : ftid::identify::toParameterSet(fit).params) {
    if (p.name == "f0_z") return p.value;
  }
  ADD_FAILURE() << "no f0_z";
  return NAN;
}

std::vector<CycleRecord> poisoned(const std::vector<CycleRecord>& genuine, double dt, double dfz) {
  std::vector<CycleRecord> out;
  for (const auto& r : genuine) {
    out.push_back(r);
    CycleRecord copy = r;
    copy.robot.robot_time += dt;
    copy.utime += static_cast<std::int64_t>(dt * 1e6);
    copy.sensor.wrench_S(2) += dfz;
    out.push_back(copy);
  }
  return out;
}

TEST(CycleStream, GenuineStreamPasses) {
  const auto g = genuineStream(3);
  std::vector<CycleRecord> clean;
  const auto rep = ftid::cell::checkCycleStream(g, 125.0, -1e300, 1e300, &clean);
  EXPECT_TRUE(rep.ok()) << rep.describe();
  EXPECT_EQ(rep.unique, g.size());
  EXPECT_EQ(rep.expected, g.size());
  EXPECT_EQ(rep.missing, 0u);
  EXPECT_EQ(clean.size(), g.size());
}

TEST(CycleStream, RepublishedSamplesOneMsLaterWithFzPlus5AreRejected) {
  for (std::uint64_t seed : {3u, 11u, 29u}) {
    const auto g = genuineStream(seed);
    const auto attack = poisoned(g, 0.001, 5.0);
    const double f0z_clean = fittedF0z(g);
    // The threat is real: fitted as received, F0_z moves by about half the injected offset.
    EXPECT_GT(std::abs(fittedF0z(attack) - f0z_clean), 1.0) << "seed " << seed;
    const auto rep = ftid::cell::checkCycleStream(attack, 125.0, -1e300, 1e300);
    EXPECT_FALSE(rep.ok()) << rep.describe();
    EXPECT_EQ(rep.received, 2 * g.size());
    EXPECT_EQ(rep.conflicts, g.size()) << rep.describe();  // each copy reuses a cycle number
    EXPECT_GE(rep.bad_spacing, g.size()) << rep.describe();
    EXPECT_NE(rep.describe().find("second publisher"), std::string::npos) << rep.describe();
  }
}

TEST(CycleStream, ForgedCycleNumbersOffTheClockAreRejected) {
  const auto g = genuineStream(5);
  auto attack = poisoned(g, 0.001, 5.0);
  for (std::size_t i = 1; i < attack.size(); i += 2) attack[i].cycle += 1000000000;  // fresh numbers
  const auto rep = ftid::cell::checkCycleStream(attack, 125.0, -1e300, 1e300);
  EXPECT_FALSE(rep.ok()) << rep.describe();
  EXPECT_EQ(rep.conflicts, 0u);
  EXPECT_GE(rep.bad_spacing, g.size());
  // Copies exactly one period later collide with the genuine next sample instead.
  const auto shifted = poisoned(g, 1.0 / 125.0, 5.0);
  const auto rep2 = ftid::cell::checkCycleStream(shifted, 125.0, -1e300, 1e300);
  EXPECT_FALSE(rep2.ok()) << rep2.describe();
  EXPECT_GT(rep2.conflicts, 0u);
}

TEST(CycleStream, ExactDuplicatesAreDroppedAndDoNotMoveF0) {
  const auto g = genuineStream(7);
  const auto dup = poisoned(g, 0.0, 0.0);  // every datagram delivered twice
  std::vector<CycleRecord> clean;
  const auto rep = ftid::cell::checkCycleStream(dup, 125.0, -1e300, 1e300, &clean);
  EXPECT_TRUE(rep.ok()) << rep.describe();
  EXPECT_EQ(rep.exact_duplicates, g.size());
  ASSERT_EQ(clean.size(), g.size());
  EXPECT_DOUBLE_EQ(fittedF0z(clean), fittedF0z(g));
}

TEST(CycleStream, GapsAreReportedAndBounded) {
  const auto g = genuineStream(9);
  std::vector<CycleRecord> few;  // ftidd skipped every 10th packet: cycle numbers stay consecutive
  std::int64_t cycle = g.front().cycle;
  for (std::size_t i = 0; i < g.size(); ++i) {
    if (i % 10 == 5) continue;
    few.push_back(g[i]);
    few.back().cycle = cycle++;
  }
  const auto rep = ftid::cell::checkCycleStream(few, 125.0, -1e300, 1e300);
  EXPECT_TRUE(rep.ok()) << rep.describe();
  EXPECT_EQ(rep.missing, g.size() - few.size());
  std::vector<CycleRecord> sparse;
  for (std::size_t i = 0; i < g.size(); ++i) {
    if (i % 3 != 0) sparse.push_back(g[i]);  // a third missing
  }
  const auto rep2 = ftid::cell::checkCycleStream(sparse, 125.0, -1e300, 1e300);
  EXPECT_FALSE(rep2.ok()) << rep2.describe();
  EXPECT_NE(rep2.describe().find("too many samples missing"), std::string::npos);
}

}  // namespace
