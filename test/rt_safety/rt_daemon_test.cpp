// Real-time safety of ftidd's loop side: one whole DaemonCycle step with the production
// kinematics, the production compensation (paper+rigid_body model from a parameter file) and the
// production sink (LcmOutbox::tryPush), a parameter swap, the production CAN sensor adapter with
// the time-consistent pairing (history, bounded wait, interpolation), and the transport codec,
// all under the allocation counter.
#include <gtest/gtest.h>

#include <unistd.h>

#include <array>
#include <atomic>
#include <cstdio>
#include <map>
#include <thread>

#include <lcm/lcm-cpp.hpp>

#include "../unit/daemon/fakes.hpp"
#include "alloc_controls.hpp"
#include "alloc_counter.hpp"
#include "ftid/daemon/adapters.hpp"
#include "ftid/daemon/daemon_cycle.hpp"
#include "ftid/drivers/can/seqpacket.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/params/parameter_set.hpp"
#include "ftid/transport/codec.hpp"
#include "ftid/transport/lcm_outbox.hpp"
#include "ftid/rt/spsc_queue.hpp"
#include "test_paths.hpp"

namespace ftid::daemon {
namespace {

std::string writeParams(const std::string& model_name, const std::string& path, double mass) {
  const effects::Model model = effects::Model::fromName(model_name);
  params::ParameterSet set;
  set.model = model.name();
  double k = 0.01;
  for (const auto& name : model.paramIndex().names()) {
    double v = name == "mass" ? mass : k;
    // A physically valid inertia (parameter files with an invalid one are refused, issue 14).
    if (name == "i_s_xx" || name == "i_s_yy") v = 0.2;
    if (name == "i_s_zz") v = 0.1;
    if (name == "i_s_xy" || name == "i_s_xz" || name == "i_s_yz") v = 0.0;
    set.params.push_back({name, v, 0.0, ""});
    k += 0.01;
  }
  set.tilt_u_rad = 0.01;
  set.tilt_v_rad = -0.02;
  params::writeParameterFile(path, set);
  return path;
}

TEST(RtDaemon, CycleStepWithProductionMathAndSinkDoesNotAllocate) {
  const std::string dir = ::testing::TempDir() + "ftid_rt_daemon_" + std::to_string(::getpid());
  const std::string p1 = writeParams("paper+rigid_body", dir + "_a.yaml", 1.5);
  const std::string p2 = writeParams("paper", dir + "_b.yaml", 2.5);
  struct RemoveOnExit {  // however the test ends
    std::string a, b;
    ~RemoveOnExit() {
      std::remove(a.c_str());
      std::remove(b.c_str());
    }
  } remove_on_exit{p1, p2};

  model::RobotKinematics kin = model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/ur10.urdf"));
  KinematicsMotionModel motion(kin);
  rt::OwnedSwapSlot<Compensation> slot(std::make_unique<ParameterFileCompensation>(p1));
  lcm::LCM lc("memq://");
  transport::LcmOutbox outbox(transport::OutboxOptions{}, &lc);
  outbox.start();
  OutboxSink sink(&outbox);
  test::FakeArm arm;
  test::FakeSensor sensor;
  sensor.sample.has_imu = true;
  sensor.sample.wrench_S << 1, 2, 3, 0.1, 0.2, 0.3;
  arm.state.q << 0.1, -1.2, 1.3, -0.4, 0.5, 0.6;
  arm.state.qd << 0.1, 0.2, -0.3, 0.4, 0.5, -0.6;
  arm.state.qdd << 1, -1, 0.5, 0.2, -0.3, 0.4;
  CycleOptions opt;
  opt.now_us = &test::fakeNowUs;
  DaemonCycle cycle(&arm, &sensor, &motion, &slot, &sink, opt);
  rt::LoopStats stats;
  rt::Mailbox<rt::LoopStats> box;
  cycle.attachLoopStats(&stats, &box, 2);

  auto tick = [&] {
    test::g_fake_now_us += 8000;
    ASSERT_EQ(cycle.waitForTick(std::chrono::milliseconds(12)), Status::kOk);
    cycle.onTick();
  };
  tick();  // warm-up outside the counter
  slot.post(std::make_unique<ParameterFileCompensation>(p2));  // built off the loop

  std::size_t allocations = 0;
  {
    ftid::test::ScopedAllocationCounter counter;
    for (int i = 0; i < 50; ++i) tick();  // includes the parameter swap in the first tick
    cycle.onMissed(1);
    allocations = counter.count();
  }
  EXPECT_EQ(allocations, 0u);
  EXPECT_EQ(cycle.paramVersion(), 2u);
  EXPECT_TRUE(cycle.lastRecord().wrench_valid);
  EXPECT_TRUE(slot.collectRetired());
  ASSERT_TRUE(outbox.waitIdle(std::chrono::seconds(5)));
  outbox.stop();
  EXPECT_EQ(outbox.counters().pushed, 51u);
}

// The production CAN sensor adapter with a sensor thread sending 1 kHz samples over the
// SOCK_SEQPACKET stand-in and a robot clock of 125 Hz: the per-sample drain into the history,
// the bounded wait for the sample that follows the robot state (ppoll), a wait that times out
// (sensor paused), the clock map and the interpolation, all under the allocation counter.
class TimedArm : public ArmStateSource {
 public:
  std::int64_t next_ns = 0;  // CLOCK_MONOTONIC time of the next state
  double robot_time = 3600.0;
  Status waitForState(std::chrono::nanoseconds, RobotStateRecord* out) noexcept override {
    rt::sleepUntilNs(next_ns);
    next_ns += 8'000'000;
    robot_time += 0.008;
    out->valid = true;
    out->robot_time = robot_time;
    out->recv_utime = realtimeNowUs();
    return Status::kOk;
  }
};

TEST(RtDaemon, CanSensorPairingAndWaitDoNotAllocate) {
  const drivers::can::SensorLayout layout =
      drivers::can::SensorLayout::fromDbc(drivers::can::loadDbc(ftid::test::sourcePath("/config/ftsensor.dbc")));
  auto pair = drivers::can::makeSeqpacketPair();
  drivers::can::CanTransport* bus = pair.a.get();
  CanSensorSource sensor(std::make_unique<drivers::can::CanFtImuSensor>(std::move(pair.b), layout),
                         drivers::can::SensorHealthOptions{});
  std::atomic<bool> stop{false}, paused{false};
  std::thread sender([&] {  // the sensor: one sample per millisecond, values linear in time
    std::array<can_frame, drivers::can::SensorLayout::kMaxMessages> frames{};
    drivers::can::SensorValues values;
    std::uint32_t counter = 0;
    std::int64_t next = rt::monotonicNs();
    while (!stop.load()) {
      next += 1'000'000;
      rt::sleepUntilNs(next);
      if (paused.load()) continue;
      values.wrench_S[2] = -10.0 + 1e-3 * static_cast<double>(counter);
      const int n = drivers::can::encodeSample(layout, values, ++counter, frames);
      for (int i = 0; i < n; ++i) bus->trySend(frames[static_cast<std::size_t>(i)]);
    }
  });
  test::FixedMotion motion;
  rt::OwnedSwapSlot<Compensation> slot(std::make_unique<test::OffsetCompensation>(Wrench::Zero()));
  TimedArm arm;
  CycleOptions opt;  // real clock, default wait bound
  DaemonCycle cycle(&arm, &sensor, &motion, &slot, nullptr, opt);
  arm.next_ns = rt::monotonicNs() + 20'000'000;
  auto tick = [&] {
    ASSERT_EQ(cycle.waitForTick(std::chrono::milliseconds(12)), Status::kOk);
    cycle.onTick();
  };
  for (int i = 0; i < 3; ++i) tick();  // warm-up outside the counter

  std::size_t allocations = 0;
  {
    ftid::test::ScopedAllocationCounter counter;
    for (int i = 0; i < 40; ++i) {
      paused.store(i == 20);  // tick 20: the sensor is paused, the wait times out
      tick();
    }
    allocations = counter.count();
  }
  stop.store(true);
  sender.join();
  EXPECT_EQ(allocations, 0u);
  const CycleCounters& c = cycle.counters();
  EXPECT_GT(c.sensor_interpolated.load(), 20u);
  EXPECT_GT(c.sensor_waits.load(), 0u);
  EXPECT_GT(c.sensor_wait_timeouts.load(), 0u);
  EXPECT_GT(c.valid.load(), 20u);
  EXPECT_GT(sensor.health().samples_complete, 200u);
}

// The sensor link renewed (docs/operations.md, "Link loss and reconnect"): the drain that finds
// the transport closed, the drain that takes a reopened transport (OwnedSwapSlot) and the drains
// after it run under the counter; opening and offering the transport is the link thread's work.
TEST(RtDaemon, CanSensorTransportReplacementDoesNotAllocate) {
  const drivers::can::SensorLayout layout =
      drivers::can::SensorLayout::fromDbc(drivers::can::loadDbc(ftid::test::sourcePath("/config/ftsensor.dbc")));
  auto first = drivers::can::makeSeqpacketPair();
  auto second = drivers::can::makeSeqpacketPair();
  drivers::can::CanTransport* bus2 = second.a.get();
  CanSensorSource sensor(std::make_unique<drivers::can::CanFtImuSensor>(std::move(first.b), layout),
                         drivers::can::SensorHealthOptions{});
  SensorHistory history;
  SensorSampleRecord latest;
  std::array<can_frame, drivers::can::SensorLayout::kMaxMessages> frames{};
  drivers::can::SensorValues values;
  values.wrench_S[2] = -12.0;
  first.a.reset();  // the peer goes away
  sensor.drain(drivers::can::realtimeNowNs() / 1000, &history, &latest);  // warm-up outside the counter
  std::size_t down_allocations = 0;
  {
    ftid::test::ScopedAllocationCounter counter;
    sensor.drain(drivers::can::realtimeNowNs() / 1000, &history, &latest);
    down_allocations = counter.count();
  }
  EXPECT_TRUE(sensor.transportDown());
  sensor.offerTransport(std::move(second.b));  // non-RT: the link thread
  std::size_t allocations = 0;
  {
    ftid::test::ScopedAllocationCounter counter;
    for (std::uint32_t k = 1; k <= 20; ++k) {
      const int n = drivers::can::encodeSample(layout, values, k, frames);
      for (int i = 0; i < n; ++i) bus2->trySend(frames[static_cast<std::size_t>(i)]);
      sensor.drain(drivers::can::realtimeNowNs() / 1000, &history, &latest);
    }
    allocations = counter.count();
  }
  sensor.collectRetired();
  EXPECT_EQ(down_allocations, 0u);
  EXPECT_EQ(allocations, 0u);
  EXPECT_EQ(sensor.reconnects(), 1u);
  EXPECT_FALSE(sensor.transportDown());
  EXPECT_TRUE(latest.valid);
  EXPECT_NEAR(latest.wrench_S(2), -12.0, 0.01);
}

TEST(RtDaemon, CodecAndQueueDoNotAllocate) {
  transport::warmUpCodec();
  CycleRecord rec;
  rec.sensor.wrench_S << 1, 2, 3, 4, 5, 6;
  ftid_lcm::cycle_sample_t cycle_msg{};
  ftid_lcm::compensated_wrench_t wrench_msg{};
  std::uint8_t buf[2048];
  static rt::SpscQueue<CycleRecord, 64> queue;
  CycleRecord out;
  std::size_t allocations = 0;
  {
    ftid::test::ScopedAllocationCounter counter;
    transport::toLcm(rec, &cycle_msg);
    transport::toLcm(rec, &wrench_msg);
    EXPECT_GT(transport::encodeInto(cycle_msg, buf, sizeof buf), 0);
    const int n = transport::encodeInto(wrench_msg, buf, sizeof buf);
    EXPECT_GT(n, 0);
    // Exactly the message's bytes: received bytes with trailing garbage are refused (issue 26).
    EXPECT_TRUE(transport::decodeFrom(buf, static_cast<std::size_t>(n), &wrench_msg));
    EXPECT_TRUE(queue.tryPush(rec));
    EXPECT_TRUE(queue.tryPop(&out));
    allocations = counter.count();
  }
  EXPECT_EQ(allocations, 0u);
  EXPECT_EQ(out.sensor.wrench_S, rec.sensor.wrench_S);
}

}  // namespace
}  // namespace ftid::daemon

// Positive controls: in this binary the counter sees a deliberate allocation of every kind.
FTID_ALLOCATION_COUNTER_CONTROLS();
