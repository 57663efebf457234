// Conversion of ftidd's cycle records to the CSV log format.
#include <gtest/gtest.h>

#include "ftid/cell/cycle_recorder.hpp"

namespace {

ftid::CycleRecord record(double t, bool robot_ok, bool sensor_ok, std::uint32_t health = 0) {
  ftid::CycleRecord r;
  r.robot.robot_time = t;
  r.robot.valid = robot_ok;
  r.robot.q.setConstant(t);
  r.robot.qd.setConstant(2 * t);
  r.robot.qdd.setConstant(3 * t);
  r.sensor.valid = sensor_ok;
  r.sensor.health_flags = health;
  r.sensor.wrench_S.setConstant(10 * t);
  r.sensor.has_imu = true;
  r.sensor.has_temp = true;
  r.sensor.temp_degC = 25 + t;
  r.cycle = static_cast<std::int64_t>(t * 125);
  return r;
}

TEST(RecordsToLog, KeepsOnlyValidSamplesInsideTheWindow) {
  std::vector<ftid::CycleRecord> recs;
  recs.push_back(record(0.000, true, true));
  recs.push_back(record(0.008, true, true));
  recs.push_back(record(0.016, false, true));  // robot invalid
  recs.push_back(record(0.024, true, false));  // sensor invalid
  recs.push_back(record(0.032, true, true, ftid::kHealthStale));  // stale
  recs.push_back(record(0.032, true, true));   // repeated time
  recs.push_back(record(0.040, true, true));
  recs.push_back(record(0.048, true, true));   // outside the window below
  ftid::cell::RecordsToLogReport rep;
  const auto log = ftid::cell::recordsToLog(recs, 0.0, 0.045, "mem", &rep);
  ASSERT_EQ(log.samples.size(), 4u);
  EXPECT_EQ(rep.converted, 4u);
  EXPECT_EQ(rep.skipped_invalid, 3u);
  EXPECT_EQ(rep.skipped_non_monotonic, 0u);
  EXPECT_DOUBLE_EQ(log.samples[3].t, 0.040);
  EXPECT_DOUBLE_EQ(log.samples[3].qd(2), 0.080);
  EXPECT_DOUBLE_EQ(log.samples[3].qdd(5), 0.120);
  EXPECT_DOUBLE_EQ(log.samples[3].wrench_S(4), 0.4);
  EXPECT_TRUE(log.has_imu);
  EXPECT_TRUE(log.has_temp);
  EXPECT_DOUBLE_EQ(log.samples[2].temp_degC, 25.032);
  ASSERT_EQ(log.extra_names.size(), 4u);
  EXPECT_EQ(log.extra_names[0], "cycle");
  EXPECT_EQ(log.extra_names[3], "host_time");  // the clock of the model's time (docs/conventions.md)
  EXPECT_EQ(log.extra_columns[0].size(), 4u);
  EXPECT_EQ(log.extra_columns[3].size(), 4u);
}

TEST(RecordsToLog, NonMonotonicRobotTimeIsDropped) {
  std::vector<ftid::CycleRecord> recs{record(0.016, true, true), record(0.008, true, true),
                                                 record(0.024, true, true)};
  ftid::cell::RecordsToLogReport rep;
  const auto log = ftid::cell::recordsToLog(recs, -1e9, 1e9, "mem", &rep);
  EXPECT_EQ(log.samples.size(), 2u);
  EXPECT_EQ(rep.skipped_non_monotonic, 1u);
}

}  // namespace
