// CanSensorSource (ftid/daemon/adapters.hpp) over the SOCK_SEQPACKET stand-in: every complete
// sample of a drain reaches the history in order with its values (not only the newest), the
// newest one carries what happened since the previous drain (counter gap) exactly once, as one
// CanFtImuSensor::tryReadLatest per cycle reports it, waitForSample() waits only as needed, and
// the driver's health flags reach the published LCM messages unchanged.
#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <string>

#include "ftid/common/clock.hpp"

#include "ftid/daemon/adapters.hpp"
#include "ftid/drivers/can/seqpacket.hpp"
#include "ftid/transport/codec.hpp"
#include "test_paths.hpp"

namespace ftid::daemon {
namespace {

struct Bench {
  drivers::can::SensorLayout layout =
      drivers::can::SensorLayout::fromDbc(drivers::can::loadDbc(ftid::test::sourcePath("/config/ftsensor.dbc")));
  drivers::can::SeqpacketPair pair = drivers::can::makeSeqpacketPair();
  drivers::can::CanTransport* bus = pair.a.get();
  CanSensorSource source;
  explicit Bench(HostClocks clocks = {}, drivers::can::SensorHealthOptions health = {})
      : source(std::make_unique<drivers::can::CanFtImuSensor>(std::move(pair.b), layout, health),
               health, clocks) {}
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

// monotonicReceiptUs against a simulated host: true time t [us], CLOCK_MONOTONIC m(t) = t + M0,
// CLOCK_REALTIME r(t) = t + R0, stepped by D at t_step. A sample is received at t_r (the kernel
// stamps r(t_r)) and both clocks are read 700 us later, at t_read. A step before the receipt or
// after the read leaves the receipt exact on the monotonic clock; a step between them moves it
// older by a forward step D, younger by a step back smaller than the 700 us, and a larger step
// back (the stamp lies after the read) makes it unknown (0).
TEST(MonotonicReceipt, MatchesTheTrueReceiptUnlessTheRealtimeClockSteppedBetweenReceiptAndRead) {
  constexpr std::int64_t kM0 = 9'000'000'000, kR0 = 1'700'000'000'000'000;
  const std::int64_t t_r = 50'000'000, t_read = t_r + 700;
  const std::int64_t m_r = t_r + kM0, m_read = t_read + kM0;
  int cases = 0;
  for (const std::int64_t d : {-1'000'000LL, -5'000LL, -1LL, 1LL, 5'000LL, 1'000'000LL}) {
    for (const std::int64_t t_step : {t_r - 1, t_r + 350, t_read + 1}) {
      auto real = [&](std::int64_t t) { return t + kR0 + (t >= t_step ? d : 0); };
      const std::int64_t got = monotonicReceiptUs(real(t_r), real(t_read), m_read);
      SCOPED_TRACE("step " + std::to_string(d) + " us at t_r + " + std::to_string(t_step - t_r));
      if (t_step <= t_r || t_step > t_read) {
        EXPECT_EQ(got, m_r);
      } else if (d > 0) {
        EXPECT_EQ(got, m_r - d);  // older by the step: never fresher than it is
      } else if (t_read - t_r + d >= 0) {
        EXPECT_EQ(got, m_r - d);  // younger by the step, at most the receipt-to-read time
        EXPECT_LE(got, m_read);
      } else {
        EXPECT_EQ(got, 0);  // the stamp lies after the read: a step back, no age to read
      }
      ++cases;
    }
  }
  EXPECT_EQ(cases, 18);
  EXPECT_EQ(monotonicReceiptUs(0, kR0, kM0), 0);              // no receipt: unknown
  EXPECT_EQ(monotonicReceiptUs(kR0 - 2 * kM0, kR0, kM0), 0);  // before the boot: unknown
}

// realtimeStepped: the offset real - mono of two reads of both clocks, against its tolerance of
// 0.5 ms + both reads' spans (slewing changes both clocks alike: the time between the reads adds
// nothing).
TEST(RealtimeStepped, AStepIsAnOffsetChangeBeyondTheReadsSpans) {
  auto read = [](std::int64_t mono, std::int64_t offset, std::int64_t span) {
    return HostClockRead{mono + offset, mono - span / 2, mono - span / 2 + span};
  };
  constexpr std::int64_t kOff = 1'700'000'000'000'000;
  const HostClockRead a = read(5'000'000, kOff, 2);
  EXPECT_FALSE(realtimeStepped(a, read(5'008'000, kOff, 2)));           // no change
  EXPECT_FALSE(realtimeStepped(a, read(5'008'000, kOff + 400, 2)));     // below 0.5 ms
  EXPECT_TRUE(realtimeStepped(a, read(5'008'000, kOff + 600, 2)));      // a 0.6 ms step
  EXPECT_TRUE(realtimeStepped(a, read(5'008'000, kOff - 95'000, 2)));   // set back 95 ms
  EXPECT_TRUE(realtimeStepped(a, read(65'000'000, kOff + 600, 2)));     // a minute later too
  EXPECT_FALSE(realtimeStepped(a, read(5'008'000, kOff + 3'000, 6'000)));  // a preempted read
}

std::int64_t g_realtime_shift_us = 0;
std::int64_t shiftedRealtimeUs() noexcept { return realtimeUs() + g_realtime_shift_us; }
std::int64_t g_monotonic_shift_us = 0;
std::int64_t shiftedMonotonicUs() noexcept { return monotonicUs() + g_monotonic_shift_us; }
/// Puts both shifts back to 0 when a test ends, however it ends.
struct ShiftReset {
  ShiftReset() = default;
  ShiftReset(const ShiftReset&) = delete;
  ShiftReset& operator=(const ShiftReset&) = delete;
  ~ShiftReset() {
    g_realtime_shift_us = 0;
    g_monotonic_shift_us = 0;
  }
};

void spinFor(std::int64_t us) {
  const std::int64_t until = monotonicUs() + us;
  while (monotonicUs() < until) {
  }
}

// The production adapter over a real socket with kernel receive timestamps: each sample's
// recv_mono_us lies within the monotonic interval in which it was sent and drained. The clock
// the source reads is shifted to act as a real-time clock that stepped between the kernel's
// stamp and the read: forward, the receipt is older by the step; back beyond the stamp, unknown.
TEST(CanSensorSource, EachSampleCarriesItsReceiptOnTheMonotonicClock) {
  const ShiftReset reset;
  for (const std::int64_t shift_us : {0LL, -1'000'000LL, 50'000LL}) {
    SCOPED_TRACE("real-time clock shifted by " + std::to_string(shift_us) + " us");
    g_realtime_shift_us = shift_us;
    Bench b(HostClocks{&shiftedRealtimeUs, &monotonicUs});
    const std::int64_t before = monotonicUs();
    for (std::uint32_t k = 1; k <= 3; ++k) b.send(k, -1.0 * k);
    SensorHistory history;
    SensorSampleRecord latest;
    b.source.drain(realtimeUs(), &history, &latest);
    const std::int64_t after = monotonicUs();
    ASSERT_EQ(history.size(), 3);
    for (int i = 0; i < 3; ++i) {
      if (shift_us < 0) {
        EXPECT_EQ(history.at(i).recv_mono_us, 0);
      } else {
        // Never later than the truth; earlier by at most the clocks' read span (a preempted
        // read on a busy host: up to milliseconds).
        EXPECT_GE(history.at(i).recv_mono_us, before - shift_us - 5'000);
        EXPECT_LE(history.at(i).recv_mono_us, after - shift_us);
      }
    }
    EXPECT_EQ(latest.recv_mono_us, history.newest().recv_mono_us);
    if (shift_us == 0) {  // exact: the samples' spacing is kept
      EXPECT_GT(history.at(2).recv_mono_us, history.at(0).recv_mono_us);
    }
  }
}

// Frames wait 60 ms in the socket (the loop stalled), and meanwhile the real-time clock is set
// back 50 ms: by their kernel stamps they would look 10 ms old, fresh. The source sees the step
// between its two clock reads and gives them the oldest receipt they can have, the moment the
// socket was last found empty; then the driver's own staleness test is on the monotonic age.
TEST(CanSensorSource, AStepWhileFramesWaitGivesThemTheirOldestPossibleReceipt) {
  const ShiftReset reset;
  Bench b(HostClocks{&shiftedRealtimeUs, &monotonicUs});
  SensorHistory history;
  SensorSampleRecord latest;
  b.source.drain(realtimeUs(), &history, &latest);  // empties the socket
  const std::int64_t emptied = monotonicUs();
  for (std::uint32_t k = 1; k <= 3; ++k) b.send(k, -1.0 * k);
  spinFor(60'000);
  g_realtime_shift_us = -50'000;
  b.source.drain(shiftedRealtimeUs(), &history, &latest);
  ASSERT_EQ(history.size(), 3);
  for (int i = 0; i < 3; ++i) {
    EXPECT_GT(history.at(i).recv_mono_us, 0);
    EXPECT_LE(history.at(i).recv_mono_us, emptied);
  }
  // By the stamps alone: a receipt 50 ms later than the true one.
  const std::int64_t naive =
      monotonicReceiptUs(history.newest().recv_utime, shiftedRealtimeUs(), monotonicUs());
  EXPECT_GT(naive, emptied + 40'000);
  EXPECT_NE(latest.health_flags & kHealthStale, 0u);  // 60 ms old on the monotonic clock
}

// Frames queued before the first drain: the clocks' first read is at construction, so a step
// before any drain is seen too. Their receipts are unknown (no emptying read yet): stale.
TEST(CanSensorSource, AStepBeforeTheFirstDrainIsSeen) {
  const ShiftReset reset;
  Bench b(HostClocks{&shiftedRealtimeUs, &monotonicUs});
  for (std::uint32_t k = 1; k <= 3; ++k) b.send(k, -1.0 * k);
  spinFor(60'000);
  g_realtime_shift_us = -50'000;  // by the stamps: 10 ms old
  SensorHistory history;
  SensorSampleRecord latest;
  b.source.drain(shiftedRealtimeUs(), &history, &latest);
  ASSERT_EQ(history.size(), 3);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(history.at(i).recv_mono_us, 0);
}

// The driver's stale flag follows the monotonic age: a sample received a moment ago is not
// flagged stale by a drain after the real-time clock jumped 10 s forward (the stale timeout is
// 1 s here, so a busy host cannot make the sample old in between).
TEST(CanSensorSource, AForwardStepAfterTheReceiptDoesNotMakeAFreshSampleStale) {
  const ShiftReset reset;
  drivers::can::SensorHealthOptions health;
  health.stale_timeout_ns = 1'000'000'000;
  Bench b(HostClocks{&shiftedRealtimeUs, &monotonicUs}, health);
  SensorHistory history;
  SensorSampleRecord latest;
  b.send(1, -1.0);
  ASSERT_TRUE(b.source.waitForSample(0, std::chrono::milliseconds(0), &history));  // pumped
  g_realtime_shift_us = 10'000'000;
  b.source.drain(shiftedRealtimeUs(), &history, &latest);
  EXPECT_EQ(latest.counter, 1);
  EXPECT_EQ(latest.health_flags & kHealthStale, 0u);
  EXPECT_TRUE(latest.valid);
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

// The one health-flag set (ftid/common/sensor_health.hpp): what the CAN driver flags a sample with
// is what subscribers read in sensor_sample_t.health_flags and compensated_wrench_t's
// sensor_health_flags, bit for bit. The reference is a second SampleAssembler (the driver alone)
// fed the same frames; each step also states the bits it must show, so a renumbering or a
// mapping anywhere between the driver and the wire fails here.
TEST(CanSensorSource, DriverHealthFlagsReachThePublishedMessageUnchanged) {
  namespace can = drivers::can;
  can::SensorHealthOptions options;
  options.stale_timeout_ns = 10'000'000'000;  // 10 s: a loaded machine never makes a step stale
  const can::SensorLayout layout =
      can::SensorLayout::fromDbc(can::loadDbc(ftid::test::sourcePath("/config/ftsensor.dbc")));
  can::SeqpacketPair pair = can::makeSeqpacketPair();
  can::CanTransport* bus = pair.a.get();
  // The source's monotonic clock can be moved on (the stale step below); its real-time clock is
  // the kernel stamps' own.
  CanSensorSource source{std::make_unique<can::CanFtImuSensor>(std::move(pair.b), layout), options,
                         HostClocks{&realtimeUs, &shiftedMonotonicUs}};
  can::SampleAssembler reference(layout, options);

  auto sendFrame = [&](const can_frame& f) {
    ASSERT_EQ(bus->trySend(f), can::IoResult::kOk);
    can::ReceivedFrame rf;
    rf.frame = f;
    rf.rx_time_ns = can::realtimeNowNs();
    reference.feed(rf);
  };
  auto sendSample = [&](std::uint32_t counter, double fx, std::uint32_t status_word) {
    std::array<can_frame, can::SensorLayout::kMaxMessages> frames{};
    can::SensorValues v;
    v.wrench_S[0] = fx;
    v.status_word = status_word;
    const int n = can::encodeSample(layout, v, counter, frames);
    for (int i = 0; i < n; ++i) sendFrame(frames[static_cast<std::size_t>(i)]);
  };
  auto sendErrorFrame = [&](std::uint32_t error_class) {
    can_frame f{};
    f.can_id = CAN_ERR_FLAG | error_class;
    f.len = CAN_ERR_DLC;
    sendFrame(f);
  };
  SensorHistory history;
  // One cycle: drain, publish through the codec, decode as a subscriber does.
  auto publishedAfterDrain = [&](std::int64_t now_ns, std::uint32_t expected_bits) {
    CycleRecord rec;
    source.drain(now_ns / 1000, &history, &rec.sensor);
    can::SensorSample driver;
    reference.readLatest(driver, now_ns);
    EXPECT_EQ(driver.health_flags, expected_bits);

    ftid_lcm::cycle_sample_t cycle_msg;
    transport::toLcm(rec, &cycle_msg);
    ftid_lcm::compensated_wrench_t wrench_msg;
    transport::toLcm(rec, &wrench_msg);
    std::array<std::uint8_t, 4096> buf{};
    ftid_lcm::cycle_sample_t cycle_rx;
    ftid_lcm::compensated_wrench_t wrench_rx;
    const int n_cycle = transport::encodeInto(cycle_msg, buf.data(), buf.size());
    EXPECT_GT(n_cycle, 0);
    EXPECT_TRUE(transport::decodeFrom(buf.data(), static_cast<std::size_t>(n_cycle), &cycle_rx));
    const int n_wrench = transport::encodeInto(wrench_msg, buf.data(), buf.size());
    EXPECT_GT(n_wrench, 0);
    EXPECT_TRUE(transport::decodeFrom(buf.data(), static_cast<std::size_t>(n_wrench), &wrench_rx));
    EXPECT_EQ(static_cast<std::uint32_t>(cycle_rx.sensor.health_flags), driver.health_flags);
    EXPECT_EQ(static_cast<std::uint32_t>(wrench_rx.sensor_health_flags), driver.health_flags);
    EXPECT_EQ(cycle_rx.sensor.valid, driver.valid);
  };
  auto step = [&](const char* what, std::uint32_t expected_bits) {
    SCOPED_TRACE(what);
    publishedAfterDrain(can::realtimeNowNs(), expected_bits);
  };

  step("no sample yet", kHealthStale | kHealthNoData);
  sendSample(1, 1.0, 0);
  step("a clean sample", kHealthOk);
  sendSample(1, 1.0, 0);
  step("the same counter again", kHealthCounterGap | kHealthCounterRepeat);
  sendSample(5, 1.0, 0);
  step("samples 2..4 lost", kHealthCounterGap);
  sendSample(6, 350.0, 0);  // rated Fx range +-300 N
  step("Fx out of range", kHealthOutOfRange);
  sendSample(7, 1.0, 0x0001);
  step("status word fault", kHealthStatusError);
  sendErrorFrame(CAN_ERR_CRTL);
  sendSample(8, 1.0, 0);
  step("an error frame", kHealthErrorFrame);
  sendErrorFrame(CAN_ERR_BUSOFF);
  step("bus-off", kHealthErrorFrame | kHealthBusOff);
  sendSample(9, 1.0, 0);
  step("back on the bus", kHealthOk);
  sendSample(9, 1.0, 0);
  sendSample(10, 1.0, 0);
  step("a repeat followed by a clean sample in one cycle", kHealthOk);  // not an interval event
  {
    SCOPED_TRACE("stale");
    const ShiftReset reset;
    g_monotonic_shift_us = 60'000'000;  // a minute later on the source's clock (its ages)
    publishedAfterDrain(can::realtimeNowNs() + 60'000'000'000, kHealthStale);
  }
}

}  // namespace
}  // namespace ftid::daemon
