// LCM log files: ftid's writer/reader against LCM's own lcm::LogFile, and conversion of recorded
// cycle samples to the CSV log format.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <random>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "ftid/common/error.hpp"
#include "ftid/logio/log.hpp"
#include "ftid/transport/codec.hpp"
#include "ftid/transport/lcm_log.hpp"
#include "ftid/transport/lcm_to_csv.hpp"
#include "test_records.hpp"

namespace ftid::transport {
namespace {

std::string tempPath(const std::string& name) {
  return ::testing::TempDir() + "ftid_lcmlog_" + std::to_string(::getpid()) + "_" + name;
}

std::vector<std::uint8_t> encodeCycle(const CycleRecord& r) {
  ftid_lcm::cycle_sample_t m{};
  toLcm(r, &m);
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
  EXPECT_GT(encodeInto(m, buf.data(), buf.size()), 0);
  return buf;
}

TEST(LcmLog, OurWriterIsReadableByLcmLogFile) {
  const std::string path = tempPath("w.lcm");
  {
    LcmLogWriter w(path);
    const std::string a = "hello";
    const std::uint8_t b[3] = {1, 2, 3};
    w.write(111, "CHAN_A", a.data(), a.size());
    w.write(222, "CHAN_LONGER_NAME", b, sizeof b);
    w.write(333, "EMPTY", nullptr, 0);
    EXPECT_EQ(w.eventsWritten(), 3u);
  }
  lcm::LogFile log(path, "r");
  ASSERT_TRUE(log.good());
  const lcm::LogEvent* e = log.readNextEvent();
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->eventnum, 0);
  EXPECT_EQ(e->timestamp, 111);
  EXPECT_EQ(e->channel, "CHAN_A");
  ASSERT_EQ(e->datalen, 5);
  EXPECT_EQ(std::string(static_cast<const char*>(e->data), 5), "hello");
  e = log.readNextEvent();
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->eventnum, 1);
  EXPECT_EQ(e->timestamp, 222);
  EXPECT_EQ(e->channel, "CHAN_LONGER_NAME");
  ASSERT_EQ(e->datalen, 3);
  EXPECT_EQ(static_cast<const std::uint8_t*>(e->data)[2], 3);
  e = log.readNextEvent();
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->channel, "EMPTY");
  EXPECT_EQ(e->datalen, 0);
  EXPECT_EQ(log.readNextEvent(), nullptr);
  std::remove(path.c_str());
}

TEST(LcmLog, OurReaderReadsLcmLogFileOutput) {
  const std::string path = tempPath("r.lcm");
  {
    lcm::LogFile log(path, "w");
    ASSERT_TRUE(log.good());
    for (int i = 0; i < 5; ++i) {
      lcm::LogEvent ev{};
      ev.eventnum = i;
      ev.timestamp = 1000 + i;
      ev.channel = "X" + std::to_string(i);
      std::uint8_t payload[4] = {static_cast<std::uint8_t>(i), 9, 8, 7};
      ev.datalen = 4;
      ev.data = payload;
      ASSERT_EQ(log.writeEvent(&ev), 0);
    }
  }
  LcmLogReader reader(path);
  LcmLogEvent ev;
  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(reader.next(&ev));
    EXPECT_EQ(ev.timestamp_us, 1000 + i);
    EXPECT_EQ(ev.channel, "X" + std::to_string(i));
    ASSERT_EQ(ev.data.size(), 4u);
    EXPECT_EQ(ev.data[0], i);
  }
  EXPECT_FALSE(reader.next(&ev));
  std::remove(path.c_str());
}

TEST(LcmLog, TruncatedLastEventEndsTheLogAndGarbageIsAnError) {
  const std::string path = tempPath("t.lcm");
  {
    LcmLogWriter w(path);
    const std::string d(100, 'x');
    w.write(1, "A", d.data(), d.size());
    w.write(2, "A", d.data(), d.size());
  }
  // Cut the second event in half.
  std::ifstream in(path, std::ios::binary);
  std::ostringstream all;
  all << in.rdbuf();
  const std::string bytes = all.str();
  in.close();
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size() - 50));
  }
  {
    LcmLogReader reader(path);
    LcmLogEvent ev;
    EXPECT_TRUE(reader.next(&ev));
    EXPECT_FALSE(reader.next(&ev));
  }
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << std::string(64, 'g');
  }
  LcmLogReader reader(path);
  LcmLogEvent ev;
  try {
    reader.next(&ev);
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("offset 0"), std::string::npos) << e.what();
  }
  std::remove(path.c_str());
  EXPECT_THROW(LcmLogReader{tempPath("does_not_exist.lcm")}, DataError);
}

TEST(LcmToCsv, ConvertsValidCyclesAndSkipsInvalidOnes) {
  const std::string path = tempPath("cycles.lcm");
  std::mt19937_64 rng(11);
  std::vector<CycleRecord> written;
  {
    LcmLogWriter w(path);
    for (int i = 0; i < 20; ++i) {
      CycleRecord r = test::randomCycleRecord(rng, i);
      if (i == 5) r.sensor.valid = false;       // stale/invalid sensor: skipped
      if (i == 6) r.robot.valid = false;        // invalid robot: skipped
      if (i == 7) r.robot.robot_time = 0.0;     // goes backwards: skipped
      const auto buf = encodeCycle(r);
      w.write(r.utime, "FTID_CYCLE", buf.data(), buf.size());
      const std::string other = "noise";
      w.write(r.utime, "OTHER", other.data(), other.size());
      if (i != 5 && i != 6 && i != 7) written.push_back(r);
    }
    const std::string junk = "not a cycle sample";
    w.write(0, "FTID_CYCLE", junk.data(), junk.size());
  }
  LcmToLogReport report;
  const logio::LogData log = lcmLogToLogData(path, LcmToLogOptions{}, &report);
  EXPECT_EQ(report.events, 41u);
  EXPECT_EQ(report.on_channel, 21u);
  EXPECT_EQ(report.skipped_invalid, 2u);
  EXPECT_EQ(report.skipped_non_monotonic, 1u);
  EXPECT_EQ(report.decode_errors, 1u);
  EXPECT_EQ(report.converted, written.size());
  ASSERT_EQ(log.samples.size(), written.size());
  EXPECT_TRUE(log.has_imu);
  EXPECT_TRUE(log.has_temp);
  for (std::size_t i = 0; i < written.size(); ++i) {
    EXPECT_EQ(log.samples[i].t, written[i].robot.robot_time);
    EXPECT_EQ(log.samples[i].q, written[i].robot.q);
    EXPECT_EQ(log.samples[i].qdd, written[i].robot.qdd);
    EXPECT_EQ(log.samples[i].wrench_S, written[i].sensor.wrench_S);
    EXPECT_EQ(log.samples[i].w_S, written[i].sensor.imu_w_S);
    EXPECT_EQ(log.samples[i].temp_degC, written[i].sensor.temp_degC);
    EXPECT_EQ(log.extra_columns[0][i], static_cast<double>(written[i].cycle));
  }

  // Through the CSV format and back (the file `ftid analyze` reads).
  const std::string csv = tempPath("cycles.csv");
  logio::writeLog(csv, log);
  const logio::LogData back = logio::readLog(csv);
  ASSERT_EQ(back.samples.size(), written.size());
  for (std::size_t i = 0; i < written.size(); ++i) {
    EXPECT_NEAR(back.samples[i].t, written[i].robot.robot_time, 1e-9);
    EXPECT_NEAR((back.samples[i].wrench_S - written[i].sensor.wrench_S).norm(), 0.0, 1e-9);
    EXPECT_NEAR((back.samples[i].q - written[i].robot.q).norm(), 0.0, 1e-9);
  }
  EXPECT_GE(back.extraIndex("sensor_age_ms"), 0);

  // keep_invalid keeps the invalid rows (but still drops the non-monotonic one).
  LcmToLogOptions keep;
  keep.keep_invalid = true;
  EXPECT_EQ(lcmLogToLogData(path, keep).samples.size(), written.size() + 2);

  // A channel without samples is an error naming the file.
  LcmToLogOptions wrong;
  wrong.channel = "NOPE";
  try {
    lcmLogToLogData(path, wrong);
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("NOPE"), std::string::npos);
  }
  std::remove(path.c_str());
  std::remove(csv.c_str());
}

TEST(LcmToCsv, OmitsImuColumnsWhenASampleHasNoImu) {
  const std::string path = tempPath("noimu.lcm");
  std::mt19937_64 rng(12);
  {
    LcmLogWriter w(path);
    for (int i = 0; i < 3; ++i) {
      CycleRecord r = test::randomCycleRecord(rng, i);
      if (i == 1) r.sensor.has_imu = false;
      const auto buf = encodeCycle(r);
      w.write(r.utime, "FTID_CYCLE", buf.data(), buf.size());
    }
  }
  const logio::LogData log = lcmLogToLogData(path, LcmToLogOptions{});
  EXPECT_EQ(log.samples.size(), 3u);
  EXPECT_FALSE(log.has_imu);
  EXPECT_TRUE(log.has_temp);
  std::remove(path.c_str());
}

}  // namespace
}  // namespace ftid::transport
