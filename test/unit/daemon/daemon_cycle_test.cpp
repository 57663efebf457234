// DaemonCycle against fakes (no threads unless stated): compensation, stale/invalid/non-finite
// inputs, missed cycles, and parameter reloads that never cost a cycle.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <thread>

#include "fakes.hpp"
#include "ftid/daemon/daemon_cycle.hpp"
#include "ftid/common/error.hpp"
#include "ftid/daemon/reloader.hpp"

namespace ftid::daemon {
namespace {

using test::FakeArm;
using test::FakeSensor;
using test::FixedMotion;
using test::OffsetCompensation;
using test::RecordingSink;

Wrench wrench(double fx, double fy, double fz, double tx, double ty, double tz) {
  Wrench w;
  w << fx, fy, fz, tx, ty, tz;
  return w;
}

struct Rig {
  FakeArm arm;
  FakeSensor sensor;
  FixedMotion motion;
  rt::OwnedSwapSlot<Compensation> slot;
  RecordingSink sink;
  std::unique_ptr<DaemonCycle> cycle;
  /// separate_mono: the cycle and the sensor read a monotonic clock of their own
  /// (test::fakeMonoUs), so that a test can step the real-time one alone.
  explicit Rig(std::unique_ptr<Compensation> initial = nullptr, bool separate_mono = false)
      : slot(std::move(initial)) {
    CycleOptions opt;
    opt.stale_timeout_us = 20'000;
    opt.now_us = &test::fakeNowUs;
    if (separate_mono) {
      opt.mono_now_us = &test::fakeMonoUs;
      sensor.mono_now_us = &test::fakeMonoUs;
    }
    cycle = std::make_unique<DaemonCycle>(&arm, &sensor, &motion, &slot, &sink, opt);
    sensor.sample.wrench_S = wrench(1, 2, 3, 0.1, 0.2, 0.3);
  }
  // One tick as the executor runs it; the clocks advance by the steps given [us].
  void tick(std::int64_t real_step_us = 8000, std::int64_t mono_step_us = 8000) {
    test::g_fake_now_us += real_step_us;
    test::g_fake_mono_us += mono_step_us;
    ASSERT_EQ(cycle->waitForTick(std::chrono::milliseconds(12)), Status::kOk);
    cycle->onTick();
  }
  const CycleRecord& last() const {
    return sink.records[static_cast<std::size_t>(sink.count - 1)];
  }
};

TEST(DaemonCycle, CompensatesValidInputsAndPublishesEveryCycle) {
  const Wrench offset = wrench(0.5, -1, 2, 0.01, 0.02, -0.03);
  Rig rig(std::make_unique<OffsetCompensation>(offset));
  for (int i = 0; i < 5; ++i) rig.tick();
  ASSERT_EQ(rig.sink.count, 5);
  for (int i = 0; i < 5; ++i) {
    const auto& r = rig.sink.records[static_cast<std::size_t>(i)];
    EXPECT_EQ(r.cycle, i);
    EXPECT_TRUE(r.wrench_valid);
    EXPECT_EQ(r.fault_bits, 0u);
    EXPECT_TRUE(r.contact_S.isApprox(rig.sensor.sample.wrench_S - offset));
    EXPECT_EQ(r.modelled_S, offset);
    EXPECT_EQ(r.sensor.wrench_S, rig.sensor.sample.wrench_S);
    EXPECT_EQ(r.sensor_age_us, 300);
    EXPECT_EQ(r.param_version, 1);
  }
  EXPECT_DOUBLE_EQ(rig.last().robot.robot_time, 100.0 + 5 * 0.008);
  EXPECT_EQ(rig.cycle->counters().valid.load(), 5u);
  EXPECT_EQ(rig.cycle->counters().cycles.load(), 5u);
}

TEST(DaemonCycle, WithoutParametersPublishesRawButInvalid) {
  Rig rig;
  rig.tick();
  ASSERT_EQ(rig.sink.count, 1);
  EXPECT_FALSE(rig.last().wrench_valid);
  EXPECT_EQ(rig.last().contact_S, Wrench::Zero());
  EXPECT_EQ(rig.last().sensor.wrench_S, rig.sensor.sample.wrench_S);
  EXPECT_EQ(rig.last().param_version, 0);
  EXPECT_EQ(rig.cycle->counters().no_parameters.load(), 1u);
}

TEST(DaemonCycle, StaleSensorIsFlaggedAndNeverCompensated) {
  Rig rig(std::make_unique<OffsetCompensation>(Wrench::Zero()));
  rig.sensor.follow_clock = false;
  rig.sensor.sample.recv_utime = test::g_fake_now_us - 15000;  // 23 ms old at the next tick
  rig.sensor.sample.recv_mono_us = rig.sensor.sample.recv_utime;  // one fake clock serves both
  rig.tick();
  rig.tick();
  const auto& r = rig.last();
  EXPECT_FALSE(r.wrench_valid);
  EXPECT_FALSE(r.sensor.valid);
  EXPECT_NE(r.sensor.health_flags & kHealthStale, 0u);
  EXPECT_NE(r.fault_bits & kFaultSensorStale, 0u);
  EXPECT_EQ(r.contact_S, Wrench::Zero());
  EXPECT_EQ(rig.cycle->counters().stale_sensor.load(), 2u);
  EXPECT_NE(rig.cycle->faults().bits() & kFaultSensorStale, 0u);

  // Never received anything: stale as well.
  rig.sensor.sample.recv_utime = 0;
  rig.sensor.sample.recv_mono_us = 0;
  rig.tick();
  EXPECT_FALSE(rig.last().wrench_valid);
  EXPECT_NE(rig.last().fault_bits & kFaultSensorStale, 0u);

  // Fresh again: valid again.
  rig.sensor.follow_clock = true;
  rig.tick();
  EXPECT_TRUE(rig.last().wrench_valid);
}

// Issue 26: ages are measured on the host's monotonic clock. The sensor falls silent; about
// 100 ms later the real-time clock is set back (NTP, an operator) so that on it the last sample
// looks a few ms old. It is over 100 ms old: the cycle stays stale and publishes the true age.
// Then the sensor resumes across the step and its samples are fresh again.
TEST(DaemonCycle, ARealtimeClockStepBackNeverMakesAnOldSampleFresh) {
  Rig rig(std::make_unique<OffsetCompensation>(Wrench::Zero()), /*separate_mono=*/true);
  rig.tick();
  ASSERT_TRUE(rig.last().wrench_valid);
  rig.sensor.follow_clock = false;  // silent from here: the same last sample at every drain
  for (int i = 0; i < 12; ++i) rig.tick();
  EXPECT_FALSE(rig.last().wrench_valid);
  rig.tick(8000 - 95'000, 8000);  // the real-time clock steps back 95 ms
  const SensorSampleRecord& old = rig.sensor.sample;
  const std::int64_t realtime_age_us = test::g_fake_now_us - old.recv_utime;
  ASSERT_GT(realtime_age_us, 0);  // the scenario: fresh by the real-time clock
  ASSERT_LT(realtime_age_us, 20'000);
  for (int i = 0; i < 3; ++i) {
    const CycleRecord& r = rig.last();
    EXPECT_FALSE(r.wrench_valid);
    EXPECT_NE(r.fault_bits & kFaultSensorStale, 0u);
    EXPECT_EQ(r.sensor_age_us, test::g_fake_mono_us - old.recv_mono_us);
    EXPECT_GT(r.sensor_age_us, 100'000);
    rig.tick();
  }
  rig.sensor.follow_clock = true;
  rig.tick();
  EXPECT_TRUE(rig.last().wrench_valid);
  EXPECT_EQ(rig.last().sensor_age_us, 300);
}

TEST(DaemonCycle, SensorInvalidatedByTheDriverIsNotCompensated) {
  Rig rig(std::make_unique<OffsetCompensation>(Wrench::Zero()));
  rig.sensor.sample.valid = false;
  rig.sensor.sample.health_flags = kHealthOutOfRange;
  rig.tick();
  EXPECT_FALSE(rig.last().wrench_valid);
  EXPECT_NE(rig.last().fault_bits & kFaultSensorInvalid, 0u);
  EXPECT_EQ(rig.last().fault_bits & kFaultSensorStale, 0u);
  EXPECT_EQ(rig.last().sensor.health_flags, static_cast<std::uint32_t>(kHealthOutOfRange));
}

TEST(DaemonCycle, NonFiniteInputsAreFlaggedNotPropagated) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Rig rig(std::make_unique<OffsetCompensation>(Wrench::Zero()));
  rig.sensor.sample.wrench_S(4) = nan;
  rig.tick();
  EXPECT_FALSE(rig.last().wrench_valid);
  EXPECT_NE(rig.last().sensor.health_flags & kHealthNonFinite, 0u);
  EXPECT_TRUE(rig.last().contact_S.allFinite());

  rig.sensor.sample.wrench_S(4) = 0.2;
  rig.sensor.sample.has_imu = true;
  rig.sensor.sample.imu_w_S(1) = std::numeric_limits<double>::infinity();
  rig.tick();
  EXPECT_FALSE(rig.last().wrench_valid);
  rig.sensor.sample.imu_w_S(1) = 0.0;

  rig.arm.state.q(2) = nan;
  rig.tick();
  EXPECT_FALSE(rig.last().wrench_valid);
  EXPECT_FALSE(rig.last().robot.valid);
  EXPECT_NE(rig.last().fault_bits & kFaultRobotStopped, 0u);
  EXPECT_EQ(rig.cycle->counters().invalid_robot.load(), 1u);
  rig.arm.state.q(2) = 0.0;
  rig.tick();
  EXPECT_TRUE(rig.last().wrench_valid);
}

class NanCompensation : public Compensation {
 public:
  double tiltU() const noexcept override { return 0.0; }
  double tiltV() const noexcept override { return 0.0; }
  bool compute(const effects::SampleContext&, Wrench* contact, Wrench* modelled) noexcept override {
    contact->setConstant(std::numeric_limits<double>::quiet_NaN());
    modelled->setConstant(std::numeric_limits<double>::quiet_NaN());
    return true;  // claims success: the cycle must still catch the NaN
  }
};

TEST(DaemonCycle, NonFiniteModelOutputIsInvalid) {
  Rig rig(std::make_unique<NanCompensation>());
  rig.tick();
  EXPECT_FALSE(rig.last().wrench_valid);
  EXPECT_TRUE(rig.last().contact_S.allFinite());
  EXPECT_EQ(rig.cycle->counters().model_failures.load(), 1u);
}

TEST(DaemonCycle, MissedRobotPacketsAreCountedAndFlagged) {
  Rig rig(std::make_unique<OffsetCompensation>(Wrench::Zero()));
  rig.arm.next_status = Status::kTimeout;
  EXPECT_EQ(rig.cycle->waitForTick(std::chrono::milliseconds(12)), Status::kTimeout);
  EXPECT_EQ(rig.cycle->onMissed(1), CycleAction::kContinue);
  EXPECT_EQ(rig.cycle->counters().missed.load(), 1u);
  EXPECT_NE(rig.cycle->faults().bits() & kFaultRobotTimeout, 0u);
  EXPECT_EQ(rig.sink.count, 0);
}

TEST(DaemonCycle, FullSinkIsCountedNotBlocking) {
  Rig rig(std::make_unique<OffsetCompensation>(Wrench::Zero()));
  rig.sink.accept = false;
  rig.tick();
  EXPECT_EQ(rig.cycle->counters().sink_dropped.load(), 1u);
  EXPECT_NE(rig.cycle->faults().bits() & kFaultPublishDropped, 0u);
}

TEST(DaemonCycle, ReloadSwapsParametersAtTheNextCycleAndFreesTheOldOffLoop) {
  const int alive_before = OffsetCompensation::alive.load();
  {
    Rig rig(std::make_unique<OffsetCompensation>(wrench(1, 0, 0, 0, 0, 0)));
    rig.tick();
    EXPECT_EQ(rig.last().modelled_S(0), 1.0);
    rig.slot.post(std::make_unique<OffsetCompensation>(wrench(2, 0, 0, 0, 0, 0)));
    EXPECT_EQ(OffsetCompensation::alive.load() - alive_before, 2);
    rig.tick();  // swaps at the start of this cycle
    EXPECT_EQ(rig.last().modelled_S(0), 2.0);
    EXPECT_TRUE(rig.last().wrench_valid);
    EXPECT_EQ(rig.last().param_version, 2);
    EXPECT_EQ(rig.last().cycle, 1);  // no cycle skipped
    // The loop only retired the old object; it is freed by the non-RT side.
    EXPECT_EQ(OffsetCompensation::alive.load() - alive_before, 2);
    EXPECT_TRUE(rig.slot.collectRetired());
    EXPECT_EQ(OffsetCompensation::alive.load() - alive_before, 1);
  }
  EXPECT_EQ(OffsetCompensation::alive.load(), alive_before);
}

TEST(DaemonCycle, FailedReloadKeepsTheCurrentParameters) {
  Rig rig(std::make_unique<OffsetCompensation>(wrench(1, 0, 0, 0, 0, 0)));
  ParameterReloader reloader(&rig.slot, [](const std::string& path) -> std::unique_ptr<Compensation> {
    throw ConfigError(path + ": key 'mass': must be finite");
  });
  const ReloadResult r = reloader.reload("bad.yaml", std::chrono::milliseconds(0));
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("bad.yaml"), std::string::npos);
  EXPECT_EQ(reloader.failed(), 1u);
  rig.tick();
  EXPECT_TRUE(rig.last().wrench_valid);
  EXPECT_EQ(rig.last().modelled_S(0), 1.0);
  EXPECT_EQ(rig.last().param_version, 1);
}

// A loop thread runs cycles back to back while the main thread reloads 40 times: every cycle
// is published, valid, numbered without a gap, and uses exactly one parameter version.
TEST(DaemonCycle, ReloadsUnderARunningLoopNeverCostACycle) {
  const int alive_before = OffsetCompensation::alive.load();
  {
    Rig rig(std::make_unique<OffsetCompensation>(wrench(0, 0, 0, 0, 0, 0)));
    std::atomic<int> next_offset{1};
    ParameterReloader reloader(&rig.slot, [&](const std::string&) -> std::unique_ptr<Compensation> {
      return std::make_unique<OffsetCompensation>(
          wrench(static_cast<double>(next_offset.fetch_add(1)), 0, 0, 0, 0, 0));
    });
    std::atomic<bool> stop{false};
    std::thread loop([&] {
      while (!stop.load() && rig.sink.count < RecordingSink::kCapacity - 1) {
        test::g_fake_now_us += 10;  // only the loop thread writes the fake clock
        rig.arm.state.robot_time += 10e-6;  // a new robot packet each step
        rig.arm.state.recv_utime = test::g_fake_now_us;
        rig.cycle->step(rig.arm.state, nullptr);
        std::this_thread::sleep_for(std::chrono::microseconds(200));
      }
    });
    int applied = 0;
    for (int i = 0; i < 40; ++i) {
      const ReloadResult r = reloader.reload("p.yaml", std::chrono::seconds(2));
      ASSERT_TRUE(r.ok) << r.message;
      applied += r.applied ? 1 : 0;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    stop.store(true);
    loop.join();
    reloader.collect();
    EXPECT_EQ(applied, 40);
    ASSERT_GT(rig.sink.count, 40);
    int last_version = 0;
    for (int i = 0; i < rig.sink.count; ++i) {
      const auto& r = rig.sink.records[static_cast<std::size_t>(i)];
      ASSERT_EQ(r.cycle, i);
      ASSERT_TRUE(r.wrench_valid) << "cycle " << i;
      ASSERT_GE(r.param_version, last_version);
      // Version v (1-based) is the (v-1)th object: offset fx = v - 1.
      ASSERT_EQ(r.modelled_S(0), static_cast<double>(r.param_version - 1)) << "cycle " << i;
      last_version = r.param_version;
    }
    EXPECT_EQ(last_version, 41);
    EXPECT_EQ(OffsetCompensation::alive.load() - alive_before, 1);  // only the current one
  }
  EXPECT_EQ(OffsetCompensation::alive.load(), alive_before);
}

}  // namespace
}  // namespace ftid::daemon
