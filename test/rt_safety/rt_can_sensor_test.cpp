// Real-time safety of the CAN sensor path: draining, assembling, health checks and encoding do not
// allocate (and are noexcept), whatever the frames contain.
#include <gtest/gtest.h>

#include <string>

#include "alloc_controls.hpp"
#include "alloc_counter.hpp"
#include "ftid/drivers/can/candump.hpp"
#include "ftid/drivers/can/ft_imu_sensor.hpp"
#include "ftid/drivers/can/seqpacket.hpp"
#include "test_paths.hpp"

namespace ftid::drivers::can {
namespace {

static_assert(noexcept(std::declval<FtImuSensor&>().tryReadLatest(std::declval<SensorSample&>(),
                                                                   std::int64_t{0})));
static_assert(noexcept(std::declval<SampleAssembler&>().feed(std::declval<const ReceivedFrame&>())));
static_assert(noexcept(std::declval<CanTransport&>().tryReceive(std::declval<ReceivedFrame&>())));
static_assert(noexcept(std::declval<CanTransport&>().tryReceiveBatch(
    std::declval<ReceivedFrame*>(), 1, std::declval<IoResult&>())));
static_assert(noexcept(std::declval<CanTransport&>().trySend(std::declval<const can_frame&>())));

TEST(RtCanSensor, DrainAssembleAndHealthDoNotAllocate) {
  const SensorLayout layout =
      SensorLayout::fromDbc(loadDbc(ftid::test::sourcePath("/config/ftsensor.dbc")));
  auto pair = makeSeqpacketPair();
  CanTransport& bus = *pair.a;
  CanFtImuSensor sensor(std::move(pair.b), layout);
  SensorSample sample;
  std::array<can_frame, SensorLayout::kMaxMessages> frames{};
  SensorValues values;
  can_frame error{};
  error.can_id = CAN_ERR_FLAG | CAN_ERR_CRTL;
  error.len = CAN_ERR_DLC;

  std::size_t allocations = 0;
  std::uint32_t counter = 0;
  for (int cycle = 0; cycle < 200; ++cycle) {
    ftid::test::ScopedAllocationCounter count;
    // A burst of samples per cycle, with a gap, a repeat, a lost frame, an out-of-range value and
    // an error frame now and then: every health path runs under the counter.
    for (int k = 0; k < 8; ++k) {
      values.wrench_S[2] = -10.0 - k;
      values.wrench_S[0] = (cycle % 17 == 3 && k == 2) ? 400.0 : 1.0;
      if (cycle % 13 == 5 && k == 4) counter += 3;  // gap
      if (cycle % 11 != 7 || k != 5) ++counter;     // else repeat
      const int n = encodeSample(layout, values, counter, frames);
      for (int i = 0; i < n; ++i) {
        if (cycle % 19 == 9 && k == 1 && i == 2) continue;  // lost frame
        bus.trySend(frames[static_cast<std::size_t>(i)]);
      }
      if (cycle % 7 == 0 && k == 0) bus.trySend(error);
    }
    sensor.tryReadLatest(sample);
    sensor.tryReadLatest(sample);  // nothing new: not fresh
    sensor.tryReadLatest(sample, sample.rx_time_ns + 1'000'000'000);  // stale
    allocations += count.count();
  }
  EXPECT_EQ(allocations, 0u);
  EXPECT_GT(sensor.health().samples_complete, 1000u);
  EXPECT_GT(sensor.health().counter_gaps, 0u);
  EXPECT_GT(sensor.health().counter_repeats, 0u);
  EXPECT_GT(sensor.health().samples_incomplete, 0u);
  EXPECT_GT(sensor.health().out_of_range, 0u);
  EXPECT_GT(sensor.health().error_frames, 0u);
  EXPECT_GT(sensor.health().stale_events, 0u);

  // Transport closed: still no allocation.
  pair.a.reset();
  ftid::test::ScopedAllocationCounter count;
  EXPECT_EQ(sensor.tryReadLatest(sample), Status::kFault);
  EXPECT_EQ(count.count(), 0u);
}

TEST(RtCanSensor, ReplayTransportDoesNotAllocate) {
  std::vector<CandumpRecord> records;
  for (int i = 0; i < 100; ++i) {
    records.push_back(parseCandumpLine("(1.000000) can0 1A0#0001000200030000", "mem", i + 1));
  }
  CandumpReplayTransport replay(std::move(records), /*paced=*/true);
  replay.advanceTo(2'000'000'000);
  ReceivedFrame rf;
  ftid::test::ScopedAllocationCounter count;
  int n = 0;
  while (replay.tryReceive(rf) == IoResult::kOk) ++n;
  EXPECT_EQ(n, 100);
  EXPECT_EQ(count.count(), 0u);
}

}  // namespace
}  // namespace ftid::drivers::can

// Positive controls: in this binary the counter sees a deliberate allocation of every kind.
FTID_ALLOCATION_COUNTER_CONTROLS();
