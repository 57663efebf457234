// candump log parsing/formatting and replay.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <unistd.h>

#include "ftid/common/error.hpp"
#include "ftid/drivers/can/candump.hpp"
#include "ftid/drivers/can/ft_imu_sensor.hpp"
#include "test_paths.hpp"

namespace ftid::drivers::can {
namespace {

TEST(Candump, ParsesStandardExtendedErrorRemoteFrames) {
  auto r = parseCandumpLine("(1700000000.000123) can0 1A1#DEADBEEF01020304", "x.log", 1);
  EXPECT_EQ(r.frame.rx_time_ns, 1'700'000'000'000'123'000);
  EXPECT_EQ(r.interface, "can0");
  EXPECT_EQ(r.frame.frame.can_id, 0x1A1u);
  EXPECT_EQ(r.frame.frame.len, 8);
  EXPECT_EQ(r.frame.frame.data[0], 0xDE);
  EXPECT_EQ(r.frame.frame.data[7], 0x04);

  r = parseCandumpLine("(1.5) vcan1 12345678#00", "x.log", 2);
  EXPECT_EQ(r.frame.rx_time_ns, 1'500'000'000);
  EXPECT_EQ(r.frame.frame.can_id, 0x12345678u | CAN_EFF_FLAG);
  EXPECT_EQ(r.frame.frame.len, 1);

  r = parseCandumpLine("(1700000000.000789) can0 20000004#0000080000000000", "x.log", 3);
  EXPECT_TRUE(isErrorFrame(r.frame.frame));
  EXPECT_FALSE(isExtendedFrame(r.frame.frame));
  EXPECT_EQ(r.frame.frame.can_id & CAN_ERR_MASK, static_cast<canid_t>(CAN_ERR_CRTL));
  EXPECT_EQ(r.frame.frame.data[2], 0x08);

  r = parseCandumpLine("(0.000001) can0 1A1#R4", "x.log", 4);
  EXPECT_TRUE(isRemoteFrame(r.frame.frame));
  EXPECT_EQ(r.frame.frame.len, 4);
  r = parseCandumpLine("(0.000001) can0 1A1#R", "x.log", 4);
  EXPECT_EQ(r.frame.frame.len, 0);

  r = parseCandumpLine("(0.000001) can0 123# R", "x.log", 5);  // empty payload, candump -x marker
  EXPECT_EQ(r.frame.frame.len, 0);
  r = parseCandumpLine("(0.000001) can0 123#11.22.33", "x.log", 6);
  EXPECT_EQ(r.frame.frame.len, 3);
  EXPECT_EQ(r.frame.frame.data[2], 0x33);
}

TEST(Candump, ErrorsNameFileAndLine) {
  const char* bad[] = {
      "1700000000.0 can0 1A1#00",          // no parentheses
      "(1700000000.0) can0 1A1#0",         // odd hex digits
      "(1700000000.0) can0 1A12#00",       // 4-digit id
      "(1700000000.0) can0 1A1##1001",     // CAN FD
      "(1700000000.0) can0 1A1#000102030405060708",  // 9 bytes
      "(1700000000.0) can0 1A1",           // no '#'
      "(1700000000.0) can0 1A1#00 junk",   // trailing text
  };
  for (const char* line : bad) {
    try {
      parseCandumpLine(line, "cap.log", 17);
      FAIL() << line;
    } catch (const DataError& e) {
      EXPECT_NE(std::string(e.what()).find("cap.log:17:"), std::string::npos) << e.what();
    }
  }
}

TEST(Candump, FormatParsesBack) {
  const char* lines[] = {"(1700000000.000123) can0 1A1#DEADBEEF01020304",
                         "(1700000001.999999) can0 12345678#00",
                         "(1700000002.000000) can0 20000040#0000000000000000",
                         "(1700000003.000001) can1 7FF#R8", "(1700000003.000001) can1 000#"};
  for (const char* l : lines) {
    const auto r = parseCandumpLine(l, "x", 1);
    EXPECT_EQ(formatCandumpLine(r.frame, r.interface), l);
  }
}

TEST(Candump, ReplayThroughTheSensorPacedByTheLogClock) {
  // Write a log of 3 samples (10 ms apart) and a foreign frame, from the encoder.
  const SensorLayout layout =
      SensorLayout::fromDbc(loadDbc(ftid::test::sourcePath("/config/ftsensor.dbc")));
  const std::string path = "/tmp/ftid-candump-test-" + std::to_string(getpid()) + ".log";
  {
    std::ofstream out(path);
    out << "# comment line\n\n";
    std::array<can_frame, SensorLayout::kMaxMessages> f{};
    for (std::uint32_t c = 0; c < 3; ++c) {
      SensorValues v;
      v.wrench_S[0] = 1.0 + c;
      const int n = encodeSample(layout, v, c, f);
      for (int i = 0; i < n; ++i) {
        ReceivedFrame rf;
        rf.frame = f[static_cast<std::size_t>(i)];
        rf.rx_time_ns = 1'700'000'000'000'000'000 + c * 10'000'000 + i * 100'000;
        out << formatCandumpLine(rf, "can0") << "\n";
      }
    }
    out << "(1700000000.500000) can1 123#00\n";
  }
  auto replay = std::make_unique<CandumpReplayTransport>(path, /*paced=*/true, "can0");
  CandumpReplayTransport* rp = replay.get();
  EXPECT_EQ(rp->size(), 18u);
  CanFtImuSensor sensor(std::move(replay), layout);
  SensorSample s;
  const std::int64_t t0 = 1'700'000'000'000'000'000;
  rp->advanceTo(t0 + 400'000);  // only part of sample 0
  EXPECT_EQ(sensor.tryReadLatest(s, t0 + 400'000), Status::kStale);
  rp->advanceTo(t0 + 10'600'000);  // sample 0 and 1 complete
  EXPECT_EQ(sensor.tryReadLatest(s, t0 + 10'600'000), Status::kOk);
  EXPECT_EQ(s.counter, 1u);
  EXPECT_NEAR(s.wrench_S[0], 2.0, 0.03);
  EXPECT_EQ(s.rx_time_ns, t0 + 10'500'000);
  rp->advanceTo(t0 + 100'000'000);
  EXPECT_EQ(sensor.tryReadLatest(s, t0 + 20'600'000), Status::kFault);  // end of the log
  EXPECT_EQ(s.counter, 2u);
  std::remove(path.c_str());
  EXPECT_THROW(loadCandump(path), DataError);
}

}  // namespace
}  // namespace ftid::drivers::can
