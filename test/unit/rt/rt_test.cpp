#include <gtest/gtest.h>

#include <atomic>
#include <thread>

#include "ftid/common/error.hpp"
#include "ftid/rt/cyclic_executor.hpp"
#include "ftid/rt/loop_stats.hpp"
#include "ftid/rt/mailbox.hpp"
#include "ftid/rt/rt_setup.hpp"
#include "ftid/rt/rt_thread.hpp"
#include "ftid/rt/spsc_queue.hpp"

using namespace ftid::rt;
using namespace std::chrono_literals;

TEST(SpscQueue, FifoOrderAndDropWhenFull) {
  SpscQueue<int, 4> q;
  for (int i = 0; i < 4; ++i) EXPECT_TRUE(q.tryPush(i));
  EXPECT_FALSE(q.tryPush(99));
  EXPECT_EQ(q.dropped(), 1u);
  int v = -1;
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(q.tryPop(&v));
    EXPECT_EQ(v, i);
  }
  EXPECT_FALSE(q.tryPop(&v));
  EXPECT_TRUE(q.tryPush(5));  // room again after the pops (the ring wraps)
  ASSERT_TRUE(q.tryPop(&v));
  EXPECT_EQ(v, 5);
}

TEST(SpscQueue, TwoThreadsKeepEveryItemInOrder) {
  static SpscQueue<std::uint64_t, 256> q;
  constexpr std::uint64_t kN = 50000;
  std::thread producer([] {
    for (std::uint64_t i = 0; i < kN;) {
      if (q.tryPush(i)) {
        ++i;
      } else {
        std::this_thread::yield();
      }
    }
  });
  std::uint64_t expected = 0, v = 0;
  while (expected < kN) {
    if (q.tryPop(&v)) {
      ASSERT_EQ(v, expected);
      ++expected;
    } else {
      std::this_thread::yield();
    }
  }
  producer.join();
}

struct Pair {
  std::uint64_t a = 0, b = 0;  // always written equal: a torn read would differ
};

TEST(Mailbox, LatestWinsAndNoTornReads) {
  Mailbox<Pair> m;
  Pair p;
  EXPECT_FALSE(m.readLatest(&p));
  EXPECT_FALSE(m.tryPop(&p));
  m.tryPush({1, 1});
  m.tryPush({2, 2});
  ASSERT_TRUE(m.tryPop(&p));
  EXPECT_EQ(p.a, 2u);
  EXPECT_FALSE(m.tryPop(&p));  // nothing new
  ASSERT_TRUE(m.readLatest(&p));
  EXPECT_EQ(p.b, 2u);

  static Mailbox<Pair> shared;
  std::atomic<bool> done{false};
  std::thread writer([&] {
    for (std::uint64_t i = 1; i <= 300000; ++i) shared.tryPush({i, i});
    done = true;
  });
  std::uint64_t last = 0, reads = 0;
  for (;;) {
    const bool finished = done.load();
    if (shared.tryPop(&p)) {
      ASSERT_EQ(p.a, p.b);
      ASSERT_GE(p.a, last);  // never older than a value already seen
      last = p.a;
      ++reads;
    } else if (finished) {
      break;
    }
  }
  writer.join();
  EXPECT_GT(reads, 0u);
  ASSERT_TRUE(shared.readLatest(&p));
  EXPECT_EQ(p.a, 300000u);
}

TEST(LoopStats, HistogramQuantiles) {
  LatencyHistogram h;
  for (int i = 0; i < 1000; ++i) h.add(i * 1000);  // 0..999 us
  EXPECT_EQ(h.count, 1000u);
  EXPECT_NEAR(static_cast<double>(h.quantileNs(0.5)), 500e3, 2e3);
  EXPECT_NEAR(static_cast<double>(h.quantileNs(0.99)), 990e3, 2e3);
  h.add(5'000'000);  // 5 ms: overflow bin
  EXPECT_EQ(h.overflow, 1u);
  EXPECT_EQ(h.quantileNs(1.0), 5'000'000);
  LoopStats s;
  s.recordCycle(1000, 9'000'000, 8'000'000);
  EXPECT_EQ(s.overruns, 1u);
  EXPECT_NE(s.summary().find("1 overruns"), std::string::npos);
}

namespace {
struct TimerCycle {
  int n = 0;
  std::int64_t first = 0, last = 0;
  CycleAction onTimer(std::int64_t deadline) noexcept {
    if (n == 0) first = deadline;
    last = deadline;
    return ++n >= 50 ? CycleAction::kStop : CycleAction::kContinue;
  }
};

struct FakeDevice {
  int ticks = 0;
  int timeouts_from = 1000;
  int missed_seen = 0;
  ftid::Status waitForTick(std::chrono::nanoseconds timeout) noexcept {
    if (ticks >= timeouts_from) {
      std::this_thread::sleep_for(timeout);
      return ftid::Status::kTimeout;
    }
    std::this_thread::sleep_for(1ms);
    ++ticks;
    return ftid::Status::kOk;
  }
  CycleAction onTick() noexcept { return CycleAction::kContinue; }
  CycleAction onMissed(std::uint32_t) noexcept {
    ++missed_seen;
    return CycleAction::kContinue;
  }
};
}  // namespace

TEST(CyclicExecutor, TimerDeadlinesAreAbsolute) {
  TimerCycle c;
  ExecutorConfig cfg;
  cfg.period = 2ms;
  LoopStats stats;
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(runTimerClocked(c, cfg, &stats), LoopExit::kCycleStopped);
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(c.n, 50);
  // Deadlines advance by whole periods (49 periods between the first and the last, plus skips).
  EXPECT_EQ((c.last - c.first) % 2'000'000, 0);
  EXPECT_EQ((c.last - c.first) / 2'000'000, 49 + static_cast<std::int64_t>(stats.missed));
  EXPECT_GT(elapsed, 0.095);
  EXPECT_EQ(stats.cycles, 50u);
}

namespace {
// Stalls once (cycle 3) for `stall`, records every deadline it is given.
struct StallingTimerCycle {
  std::chrono::nanoseconds stall{0};
  int n = 0;
  std::int64_t deadlines[10] = {};
  CycleAction onTimer(std::int64_t deadline) noexcept {
    deadlines[n] = deadline;
    if (n == 3) std::this_thread::sleep_for(stall);
    return ++n >= 10 ? CycleAction::kStop : CycleAction::kContinue;
  }
};
}  // namespace

TEST(CyclicExecutor, TimerDeadlinesCatchUpAShortOverrunWithoutLosingPeriods) {
  // A stall of 2.5 periods with catch_up_periods = 5: the late cycles run at once, each with its
  // own deadline, so the deadlines stay consecutive (a simulated controller clock loses no tick).
  StallingTimerCycle c;
  c.stall = 50ms;
  ExecutorConfig cfg;
  cfg.period = 20ms;
  cfg.catch_up_periods = 5;
  LoopStats stats;
  EXPECT_EQ(runTimerClocked(c, cfg, &stats), LoopExit::kCycleStopped);
  for (int i = 1; i < 10; ++i) EXPECT_EQ(c.deadlines[i] - c.deadlines[i - 1], 20'000'000) << i;
  EXPECT_EQ(stats.missed, 0u);
  EXPECT_GE(stats.wakeup.max_ns, 20'000'000);  // the caught-up cycles ran late, and say so
}

TEST(CyclicExecutor, TimerDeadlinesSkipAnOverrunBeyondTheCatchUp) {
  // The same stall without catch-up: the skipped periods are missed and the deadline jumps by
  // whole periods, which the cycle can count.
  StallingTimerCycle c;
  c.stall = 50ms;
  ExecutorConfig cfg;
  cfg.period = 20ms;
  LoopStats stats;
  EXPECT_EQ(runTimerClocked(c, cfg, &stats), LoopExit::kCycleStopped);
  const std::int64_t jump = c.deadlines[4] - c.deadlines[3];
  EXPECT_EQ(jump % 20'000'000, 0);
  EXPECT_GE(jump, 3 * 20'000'000);
  std::int64_t skipped = 0;
  for (int i = 1; i < 10; ++i) skipped += (c.deadlines[i] - c.deadlines[i - 1]) / 20'000'000 - 1;
  EXPECT_EQ(static_cast<std::uint64_t>(skipped), stats.missed);
}

TEST(CyclicExecutor, ZeroPeriodRunsFreeWithoutSleeping) {
  TimerCycle c;
  ExecutorConfig cfg;
  cfg.period = std::chrono::nanoseconds(0);
  LoopStats stats;
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(runTimerClocked(c, cfg, &stats), LoopExit::kCycleStopped);
  EXPECT_EQ(c.n, 50);
  EXPECT_EQ(stats.missed, 0u);
  EXPECT_EQ(stats.overruns, 0u);
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 1s);  // 50 cycles, no sleeping (not a timing test)
}

TEST(CyclicExecutor, DeviceTimeoutsAreMissedCyclesAndEndTheLoop) {
  FakeDevice d;
  d.timeouts_from = 20;
  ExecutorConfig cfg;
  cfg.period = 1ms;
  cfg.max_consecutive_missed = 3;
  LoopStats stats;
  EXPECT_EQ(runDeviceClocked(d, cfg, &stats), LoopExit::kTooManyMissed);
  EXPECT_EQ(stats.cycles, 20u);
  EXPECT_EQ(stats.missed, 3u);
  EXPECT_EQ(d.missed_seen, 3);
  EXPECT_EQ(stats.max_consecutive_missed, 3u);
}

TEST(CyclicExecutor, StopFlag) {
  FakeDevice d;
  ExecutorConfig cfg;
  std::atomic<bool> stop{true};
  LoopStats stats;
  EXPECT_EQ(runDeviceClocked(d, cfg, &stats, &stop), LoopExit::kStopRequested);
}

TEST(RtSetup, WithoutRequireRunsAndReports) {
  RealtimeConfig cfg;
  cfg.lock_memory = false;  // keep the test process unlocked
  cfg.dma_latency = false;
  cfg.priority = 10;
  bool ran = false;
  const RealtimeReport r = runInRealtimeThread(cfg, [&] { ran = true; });
  EXPECT_TRUE(ran);
  // Either SCHED_FIFO worked (root) or the refusal is listed as a problem: never silent.
  EXPECT_TRUE(r.fifo || !r.problems.empty());
  EXPECT_FALSE(r.describe().empty());
}

TEST(RtSetup, RequireTurnsFailuresIntoErrors) {
  RealtimeConfig cfg;
  cfg.lock_memory = false;
  cfg.dma_latency = false;
  cfg.require = true;
  cfg.priority = 200;  // invalid priority: always refused
  EXPECT_THROW(runInRealtimeThread(cfg, [] {}), ftid::RealtimeSetupError);
}

// The PM QoS request is power management: the packaged unit (non-root, PrivateDevices=yes) cannot
// open /dev/cpu_dma_latency, and rt.require_rt must still let ftidd run (found under systemd in
// the kernel rig). The failure is reported, not thrown.
TEST(RtSetup, RequireDoesNotExtendToTheDmaLatencyRequest) {
  RealtimeConfig cfg;
  cfg.lock_memory = false;
  cfg.require = true;
  cfg.priority = 10;
  cfg.dma_latency = true;
  cfg.dma_latency_path = "/nonexistent/cpu_dma_latency";
  bool ran = false;
  RealtimeReport r;
  try {
    r = runInRealtimeThread(cfg, [&] { ran = true; });
  } catch (const ftid::RealtimeSetupError& e) {
    // Only SCHED_FIFO may be refused here (an unprivileged test run), never the DMA request.
    EXPECT_EQ(std::string(e.what()).find("cpu_dma_latency"), std::string::npos) << e.what();
    GTEST_SKIP() << "SCHED_FIFO refused in this environment: " << e.what();
  }
  EXPECT_TRUE(ran);
  EXPECT_FALSE(r.dma_latency);
  ASSERT_FALSE(r.problems.empty());
  EXPECT_NE(r.problems.back().find("/nonexistent/cpu_dma_latency"), std::string::npos);
}

TEST(RtSetup, ExceptionsInTheBodyReachTheCaller) {
  RealtimeConfig cfg;
  cfg.enable = false;
  EXPECT_THROW(runInRealtimeThread(cfg, [] { throw ftid::DriverError("boom"); }), ftid::DriverError);
}
