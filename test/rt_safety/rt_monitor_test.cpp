// Real-time safety with the payload monitor running: the loop's hand-over (DaemonCycle::step with
// a MonitorLink attached) allocates nothing while the monitor thread drains the queue, decides and
// publishes; the monitor's own update is allocation-free too.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "../unit/daemon/fakes.hpp"
#include "alloc_controls.hpp"
#include "alloc_counter.hpp"
#include "ftid/daemon/daemon_cycle.hpp"
#include "ftid/daemon/payload_watch.hpp"

FTID_ALLOCATION_COUNTER_CONTROLS();

namespace ftid::daemon {
namespace {

TEST(RtMonitor, CycleHandOverDoesNotAllocateWithTheMonitorRunning) {
  test::FakeArm arm;
  test::FakeSensor sensor;
  sensor.sample.wrench_S << 0.0, 0.0, -20.0, 0.0, 0.0, 0.0;  // a residual: the monitor wakes up
  test::FixedMotion motion;
  motion.motion.w_S = Vec3(0.4, 0.0, 0.0);  // free motion
  rt::OwnedSwapSlot<Compensation> slot(std::make_unique<test::OffsetCompensation>(Wrench::Zero()));
  test::RecordingSink sink;
  CycleOptions opt;
  opt.now_us = &test::fakeNowUs;
  DaemonCycle cycle(&arm, &sensor, &motion, &slot, &sink, opt);
  MonitorLink link;
  cycle.attachMonitor(&link);
  std::atomic<int> reports{0};
  PayloadWatch watch(monitor::MonitorSettings{}, 4.0, &link, [&](const MonitorReport&) { ++reports; });
  watch.start();

  auto tick = [&] {
    test::g_fake_now_us += 8000;
    ASSERT_EQ(cycle.waitForTick(std::chrono::milliseconds(12)), Status::kOk);
    cycle.onTick();
  };
  tick();
  std::size_t allocations = 0;
  {
    ftid::test::ScopedAllocationCounter counter;
    for (int i = 0; i < 300; ++i) {
      tick();
      if (i % 50 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(15));  // let the thread run
    }
    allocations = counter.count();
  }
  EXPECT_EQ(allocations, 0u);
  // The monitor saw the residual: the flag rides on the wrench, not in the fault word.
  for (int i = 0; i < 200 && link.flags() == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  tick();
  watch.stop();
  EXPECT_NE(cycle.lastRecord().fault_bits & kWrenchFlagMask, 0u);
  EXPECT_EQ(cycle.faults().bits() & kWrenchFlagMask, 0u);
  EXPECT_GT(reports.load(), 0);
  EXPECT_EQ(link.dropped.load(), 0u);
}

TEST(RtMonitor, MonitorUpdateDoesNotAllocate) {
  monitor::PayloadMonitor mon{monitor::MonitorSettings{}};
  monitor::MonitorSample s;
  s.w_S = Vec3(0.3, 0.1, 0.0);
  mon.update(s);
  std::size_t allocations = 0;
  int events = 0;
  {
    ftid::test::ScopedAllocationCounter counter;
    for (int k = 1; k < 400; ++k) {
      s.t = 0.008 * k;
      s.residual_S.setZero();
      if (k > 100 && k < 160) s.residual_S(1) = 12.0;  // a push
      if (k > 250) s.residual_S(2) = -5.0;            // then a steady residual
      events += mon.update(s).has_value() ? 1 : 0;
    }
    allocations = counter.count();
  }
  EXPECT_EQ(allocations, 0u);
  EXPECT_GT(events, 0);
}

}  // namespace
}  // namespace ftid::daemon
