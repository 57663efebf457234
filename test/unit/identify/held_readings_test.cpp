// Held readings (include/ftid/samples/held_readings.hpp): rows that repeat the previous row's
// wrench bit for bit while the robot moved, which a sensor slower than the log (sample-and-hold)
// or a stalled stream leaves. The identity: identifying a log with held readings gives exactly
// the identification of the same log without those rows (only the row each reading arrived with
// counts), with a warning that says how many and how long.
#include <gtest/gtest.h>

#include <cstdio>
#include <random>
#include <string>

#include "ftid/identify/offline.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/samples/held_readings.hpp"
#include "paper_cell.hpp"
#include "test_paths.hpp"

namespace ftid::samples {
namespace {

/// A joint log of n rows at 500 Hz: the joints move every row, the wrench is fresh noise every
/// row (seeded).
logio::LogData movingLog(int n) {
  logio::LogData log;
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 0.05);
  for (int i = 0; i < n; ++i) {
    logio::LogSample s;
    s.t = i * 0.002;
    s.q.setConstant(0.001 * i);
    for (int a = 0; a < 6; ++a) s.wrench_S(a) = noise(rng);
    log.samples.push_back(s);
  }
  return log;
}

/// Each wrench held for `k` rows from row 0 (sample-and-hold of a sensor at 1/k of the log's rate).
void holdEvery(logio::LogData& log, int k) {
  for (std::size_t i = 0; i < log.samples.size(); ++i) log.samples[i].wrench_S = log.samples[i - i % k].wrench_S;
}

TEST(HeldReadings, ASensorAtAQuarterOfTheLogsRateRepeatsThreeRowsInFour) {
  logio::LogData log = movingLog(400);
  EXPECT_EQ(findHeldReadings(log).count, 0);  // fresh noise every row: nothing held
  holdEvery(log, 4);
  const HeldReadings h = findHeldReadings(log);
  EXPECT_EQ(h.count, 300);
  EXPECT_EQ(h.runs, 100);
  EXPECT_EQ(h.typical_rows, 4);
  EXPECT_NEAR(h.longest_s, 0.008, 1e-12);
  for (std::size_t i = 0; i < log.samples.size(); ++i) EXPECT_EQ(h.held[i], i % 4 == 0 ? 0 : 1) << i;
  const std::string line = describeHeldReadings(h, "run.csv");
  EXPECT_NE(line.find("run.csv: 300 rows repeat"), std::string::npos) << line;
  EXPECT_NE(line.find("median 4 rows"), std::string::npos) << line;
}

TEST(HeldReadings, AStalledStreamIsOneLongHold) {
  logio::LogData log = movingLog(500);
  for (int i = 101; i < 350; ++i) log.samples[static_cast<std::size_t>(i)].wrench_S = log.samples[100].wrench_S;
  const HeldReadings h = findHeldReadings(log);
  EXPECT_EQ(h.count, 249);
  EXPECT_EQ(h.runs, 1);
  EXPECT_NEAR(h.longest_s, 0.5, 1e-12);  // rows 100..349 show one reading; row 350 renews it
  EXPECT_NEAR(h.longest_from_s, 0.2, 1e-12);
}

// With the arm at rest too, a repeated value is what a noise-free or coarsely quantized sensor
// reads: a reading, kept.
TEST(HeldReadings, ARepeatWhileTheRobotRestsIsAReading) {
  logio::LogData log = movingLog(200);
  for (auto& s : log.samples) {
    s.q.setZero();
    s.wrench_S = log.samples.front().wrench_S;
  }
  EXPECT_EQ(findHeldReadings(log).count, 0);
  EXPECT_TRUE(describeHeldReadings(findHeldReadings(log), "x").empty());
}

// A pose log's robot state is its pose columns.
TEST(HeldReadings, APoseLogMovesThroughItsPoseColumns) {
  logio::LogData log = movingLog(40);
  log.has_joints = false;
  log.extra_names = {"rx", "ry", "rz", "gripper"};
  log.extra_columns.assign(4, std::vector<double>(40, 0.0));
  for (auto& s : log.samples) s.q.setZero();
  holdEvery(log, 2);
  EXPECT_EQ(findHeldReadings(log).count, 0);  // no pose column changes: at rest
  for (int i = 0; i < 40; ++i) log.extra_columns[3][static_cast<std::size_t>(i)] = i;
  EXPECT_EQ(findHeldReadings(log).count, 0);  // another column is not the robot's state
  for (int i = 0; i < 40; ++i) log.extra_columns[1][static_cast<std::size_t>(i)] = 0.01 * i;
  EXPECT_EQ(findHeldReadings(log).count, 20);
}

/// `ftid identify --log` on `log` (written to a file), the default model.
identify::CheckedIdentification identifyFile(const logio::LogData& log, const std::string& name) {
  const std::string path = ::testing::TempDir() + name;
  logio::writeLog(path, log);
  identify::IdentifyRequest req;
  req.log_path = path;
  req.model = identify::kDefaultModel;
  req.robot_urdf = test::sourcePath("/config/ur10.urdf");
  const identify::CheckedIdentification id = identify::identifyLogFileChecked(req, true);
  std::remove(path.c_str());
  return id;
}

// The paper's cell at 500 Hz with a sensor streaming at 125 Hz into the log (each reading held for
// four rows): the identification is bit for bit that of the log without the held rows, and warns.
// Kept, the held rows moved every estimate (the mass by 0.5 standard errors on this seed) and
// made the noise look strongly coloured.
TEST(HeldReadings, IdentifyUsesOnlyTheRowEachReadingArrivedWith) {
  sim::CellSimConfig cfg = sim::paperCellConfig(test::ur10());
  cfg.seed = 5;
  cfg.rate_hz = 500.0;
  cfg.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  logio::LogData held = sim::CellSim(cfg).run();
  holdEvery(held, 4);
  logio::LogData fresh = held;
  fresh.samples.clear();
  for (std::size_t i = 0; i < held.samples.size(); i += 4) fresh.samples.push_back(held.samples[i]);
  const identify::CheckedIdentification a = identifyFile(held, "held_readings_held.csv");
  const identify::CheckedIdentification b = identifyFile(fresh, "held_readings_fresh.csv");
  ASSERT_EQ(a.set.params.size(), b.set.params.size());
  for (std::size_t k = 0; k < a.set.params.size(); ++k) {
    EXPECT_EQ(a.set.params[k].value, b.set.params[k].value) << a.set.params[k].name;
    EXPECT_EQ(a.set.params[k].std, b.set.params[k].std) << a.set.params[k].name;
  }
  ASSERT_FALSE(a.check.warnings.empty());
  EXPECT_NE(a.check.warnings.front().find("3750 rows repeat the previous row's wrench"), std::string::npos)
      << a.check.warnings.front();
  for (const auto& w : b.check.warnings) EXPECT_EQ(w.find("repeat the previous row"), std::string::npos) << w;
  // The floor is the sensor's white noise again (0.05 N), not the near-zero of repeated rows.
  EXPECT_NEAR(a.check.noise.std(0), 0.05, 0.01);
}

}  // namespace
}  // namespace ftid::samples
