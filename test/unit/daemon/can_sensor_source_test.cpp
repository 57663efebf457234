// CanSensorSource (ftid/daemon/adapters.hpp) over the SOCK_SEQPACKET stand-in: every complete
// sample of a drain reaches the history in order with its values (not only the newest), the
// newest one carries what happened since the previous drain (counter gap) exactly once, as one
// CanFtImuSensor::tryReadLatest per cycle reports it, and waitForSample() waits only as needed.
#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <string>

#include "ftid/daemon/adapters.hpp"
#include "ftid/drivers/can/seqpacket.hpp"

namespace ftid::daemon {
namespace {

struct Bench {
  drivers::can::SensorLayout layout =
      drivers::can::SensorLayout::fromDbc(drivers::can::loadDbc(std::string(FTID_SOURCE_DIR) + "/config/ftsensor.dbc"));
  drivers::can::SeqpacketPair pair = drivers::can::makeSeqpacketPair();
  drivers::can::CanTransport* bus = pair.a.get();
  CanSensorSource source{std::make_unique<drivers::can::CanFtImuSensor>(std::move(pair.b), layout),
                         drivers::can::SensorHealthOptions{}};
  void send(std::uint32_t counter, double fz) {
    std::array<can_frame, drivers::can::SensorLayout::kMaxMessages> frames{};
    drivers::can::SensorValues v;
    v.wrench_S[2] = fz;
    const int n = drivers::can::encodeSample(layout, v, counter, frames);
    for (int i = 0; i < n; ++i) ASSERT_EQ(bus->trySend(frames[static_cast<std::size_t>(i)]), drivers::can::IoResult::kOk);
    // Samples of a real sensor are >= 0.1 ms apart; keep these at least a few us apart too (the
    // history keeps one sample per receive microsecond).
    const std::int64_t t = drivers::can::realtimeNowNs();
    while (drivers::can::realtimeNowNs() < t + 5'000) {
    }
  }
};

TEST(CanSensorSource, EverySampleOfADrainReachesTheHistory) {
  Bench b;
  for (std::uint32_t k = 1; k <= 8; ++k) b.send(k, -10.0 - static_cast<double>(k));
  b.send(12, -30.0);  // samples 9..11 lost: a counter gap before this one
  SensorHistory history;
  SensorSampleRecord latest;
  b.source.drain(drivers::can::realtimeNowNs() / 1000, &history, &latest);
  ASSERT_EQ(history.size(), 9);
  for (int i = 0; i < 8; ++i) {
    EXPECT_EQ(history.at(i).counter, i + 1);
    EXPECT_NEAR(history.at(i).wrench_S(2), -11.0 - i, 0.01);
    EXPECT_TRUE(history.at(i).valid);
    if (i > 0) {
      EXPECT_GT(history.at(i).recv_utime, history.at(i - 1).recv_utime);
    }
  }
  EXPECT_NE(history.newest().health_flags & kHealthCounterGap, 0u);
  EXPECT_EQ(latest.counter, 12);
  EXPECT_NE(latest.health_flags & kHealthCounterGap, 0u);
  EXPECT_TRUE(latest.valid);  // a gap alone does not invalidate (SensorHealthOptions default)
  EXPECT_EQ(b.source.health().samples_complete, 9u);
  EXPECT_EQ(b.source.health().samples_lost, 3u);

  b.send(13, -31.0);
  b.source.drain(drivers::can::realtimeNowNs() / 1000, &history, &latest);
  EXPECT_EQ(history.size(), 10);
  EXPECT_EQ(latest.counter, 13);
  EXPECT_EQ(latest.health_flags & kHealthCounterGap, 0u);  // reported once
}

TEST(CanSensorSource, GapSeenWhileWaitingIsReportedByTheNextDrain) {
  Bench b;
  SensorHistory history;
  SensorSampleRecord latest;
  b.send(1, -1.0);
  b.source.drain(drivers::can::realtimeNowNs() / 1000, &history, &latest);
  b.send(5, -5.0);  // gap
  EXPECT_TRUE(b.source.waitForSample(history.newest().recv_utime + 1, std::chrono::milliseconds(0),
                                     &history));
  EXPECT_EQ(history.newest().counter, 5);
  b.source.drain(drivers::can::realtimeNowNs() / 1000, &history, &latest);
  EXPECT_EQ(latest.counter, 5);
  EXPECT_NE(latest.health_flags & kHealthCounterGap, 0u);
}

TEST(CanSensorSource, WaitForSampleReturnsAsSoonAsItIsThereAndTimesOutOtherwise) {
  Bench b;
  SensorHistory history;
  b.send(1, -1.0);
  const std::int64_t after = drivers::can::realtimeNowNs() / 1000 + 1;
  // Nothing received at or after `after`: the full (short) timeout passes.
  auto t0 = std::chrono::steady_clock::now();
  EXPECT_FALSE(b.source.waitForSample(after, std::chrono::microseconds(3000), &history));
  EXPECT_GE(std::chrono::steady_clock::now() - t0, std::chrono::microseconds(3000));
  EXPECT_EQ(history.size(), 1);  // what was pending was drained meanwhile
  // A sample sent now (received after `after`): true without waiting for the timeout.
  b.send(2, -2.0);
  t0 = std::chrono::steady_clock::now();
  EXPECT_TRUE(b.source.waitForSample(after, std::chrono::seconds(5), &history));
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(4));
  EXPECT_EQ(history.newest().counter, 2);
}

}  // namespace
}  // namespace ftid::daemon
