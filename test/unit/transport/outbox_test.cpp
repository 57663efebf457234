// LcmOutbox over memq:// (in-process) and its recording (the SPSC queue itself: test/unit/rt).
#include <gtest/gtest.h>

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "ftid/common/error.hpp"
#include "ftid/transport/codec.hpp"
#include "ftid/transport/lcm_log.hpp"
#include "ftid/transport/lcm_outbox.hpp"
#include "test_records.hpp"

namespace ftid::transport {
namespace {

std::string tempPath(const std::string& name) {
  return ::testing::TempDir() + "ftid_transport_" + std::to_string(::getpid()) + "_" + name;
}

// Subscribed with subscribeFunction (function pointer + context), like LcmOutbox itself: LCM's
// member-function form trips a GCC 12 -fsanitize=vptr miscompilation in lcm-cpp-impl.hpp:88
// (false "invalid vptr"; see gcc_vptr_pmf_repro.cpp), which the sanitizer run would report.
struct Collector {
  std::mutex mutex;
  std::vector<ftid_lcm::cycle_sample_t> cycles;
  std::vector<ftid_lcm::compensated_wrench_t> wrenches;
  std::vector<ftid_lcm::loop_stats_t> stats;
  static void onCycle(const lcm::ReceiveBuffer*, const std::string&,
                      const ftid_lcm::cycle_sample_t* m, Collector* self) {
    std::lock_guard<std::mutex> l(self->mutex);
    self->cycles.push_back(*m);
  }
  static void onWrench(const lcm::ReceiveBuffer*, const std::string&,
                       const ftid_lcm::compensated_wrench_t* m, Collector* self) {
    std::lock_guard<std::mutex> l(self->mutex);
    self->wrenches.push_back(*m);
  }
  static void onStats(const lcm::ReceiveBuffer*, const std::string&,
                      const ftid_lcm::loop_stats_t* m, Collector* self) {
    std::lock_guard<std::mutex> l(self->mutex);
    self->stats.push_back(*m);
  }
};

// What a command handler saw; filled on the outbox thread.
struct SeenCommands {
  std::atomic<int> count{0};
  std::atomic<std::int64_t> id{0};
  static void record(const ftid_lcm::command_t& c, void* ctx) {
    auto* s = static_cast<SeenCommands*>(ctx);
    s->id.store(c.request_id);
    s->count.fetch_add(1);
  }
};

// An independent subscriber on the command channel: proves a command really was delivered.
void countCommand(const lcm::ReceiveBuffer*, const std::string&, const ftid_lcm::command_t*,
                  std::atomic<int>* count) {
  count->fetch_add(1);
}

void publishCommand(lcm::LCM& lc, std::int64_t request_id) {
  ftid_lcm::command_t cmd{};
  cmd.request_id = request_id;
  cmd.command = ftid_lcm::command_t::RELOAD_PARAMETERS;
  cmd.argument = "";
  ASSERT_EQ(lc.publish("FTID_COMMAND", &cmd), 0);
}

// Waits (up to 5 s) until the outbox thread has dispatched at least `n` commands.
bool waitForCommands(const SeenCommands& seen, int n) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (seen.count.load() < n) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

TEST(LcmOutbox, MemqRoundTripDeliversEveryCycleInOrder) {
  lcm::LCM lc("memq://");
  ASSERT_TRUE(lc.good());
  Collector col;
  lc.subscribeFunction("FTID_CYCLE", &Collector::onCycle, &col);
  lc.subscribeFunction("FTID_WRENCH", &Collector::onWrench, &col);
  lc.subscribeFunction("FTID_STATS", &Collector::onStats, &col);

  LcmOutbox outbox(OutboxOptions{}, &lc);
  outbox.start();
  std::mt19937_64 rng(1);
  std::vector<CycleRecord> sent;
  for (int i = 0; i < 200; ++i) {
    sent.push_back(test::randomCycleRecord(rng, i));
    ASSERT_TRUE(outbox.tryPush(sent.back()));
  }
  LoopStatsRecord stats;
  stats.cycles = 200;
  outbox.publishStats(stats);
  ASSERT_TRUE(outbox.waitIdle(std::chrono::seconds(5)));
  outbox.stop();
  while (lc.handleTimeout(0) > 0) {
  }
  ASSERT_EQ(col.cycles.size(), sent.size());
  ASSERT_EQ(col.wrenches.size(), sent.size());
  ASSERT_EQ(col.stats.size(), 1u);
  EXPECT_EQ(col.stats[0].cycles, 200);
  for (std::size_t i = 0; i < sent.size(); ++i) {
    CycleRecord a;
    fromLcm(col.cycles[i], &a);
    EXPECT_EQ(a.cycle, sent[i].cycle);
    EXPECT_EQ(a.robot.q, sent[i].robot.q);
    EXPECT_EQ(a.sensor.wrench_S, sent[i].sensor.wrench_S);
    CycleRecord b;
    fromLcm(col.wrenches[i], &b);
    EXPECT_EQ(b.cycle, sent[i].cycle);
    EXPECT_EQ(b.contact_S, sent[i].contact_S);
    EXPECT_EQ(b.modelled_S, sent[i].modelled_S);
  }
  const auto c = outbox.counters();
  EXPECT_EQ(c.pushed, 200u);
  EXPECT_EQ(c.dropped, 0u);
  EXPECT_EQ(c.published, 401u);
  EXPECT_EQ(c.publish_errors, 0u);
}

TEST(LcmOutbox, WrenchOnlyWhenCyclePublishingIsOff) {
  lcm::LCM lc("memq://");
  Collector col;
  lc.subscribeFunction("FTID_CYCLE", &Collector::onCycle, &col);
  lc.subscribeFunction("FTID_WRENCH", &Collector::onWrench, &col);
  OutboxOptions opt;
  opt.publish_cycle = false;
  LcmOutbox outbox(opt, &lc);
  outbox.start();
  std::mt19937_64 rng(2);
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(outbox.tryPush(test::randomCycleRecord(rng, i)));
  ASSERT_TRUE(outbox.waitIdle(std::chrono::seconds(5)));
  outbox.stop();
  while (lc.handleTimeout(0) > 0) {
  }
  EXPECT_EQ(col.cycles.size(), 0u);
  EXPECT_EQ(col.wrenches.size(), 10u);
}

TEST(LcmOutbox, FullQueueDropsAndCountsInsteadOfBlocking) {
  lcm::LCM lc("memq://");
  LcmOutbox outbox(OutboxOptions{}, &lc);  // not started: nobody drains
  CycleRecord r;
  std::size_t accepted = 0;
  for (std::size_t i = 0; i < LcmOutbox::kQueueCapacity + 10; ++i) accepted += outbox.tryPush(r);
  EXPECT_EQ(accepted, LcmOutbox::kQueueCapacity);
  EXPECT_EQ(outbox.counters().dropped, 10u);
}

TEST(LcmOutbox, RecordsEveryPublishedEventToAnLcmLog) {
  const std::string path = tempPath("record.lcm");
  lcm::LCM lc("memq://");
  OutboxOptions opt;
  opt.record_path = path;
  {
    LcmOutbox outbox(opt, &lc);
    outbox.start();
    std::mt19937_64 rng(3);
    for (int i = 0; i < 25; ++i) ASSERT_TRUE(outbox.tryPush(test::randomCycleRecord(rng, i)));
    outbox.publishStats(LoopStatsRecord{});
    ASSERT_TRUE(outbox.waitIdle(std::chrono::seconds(5)));
    outbox.stop();
    EXPECT_EQ(outbox.counters().recorded, 51u);
  }
  // Read it back with LCM's own reader (independent of ftid's LcmLogReader).
  lcm::LogFile log(path, "r");
  ASSERT_TRUE(log.good());
  int cycles = 0, wrenches = 0, stats = 0;
  std::int64_t expected_cycle = 0;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    if (ev->channel == "FTID_CYCLE") {
      ftid_lcm::cycle_sample_t m{};
      ASSERT_GE(m.decode(ev->data, 0, static_cast<int>(ev->datalen)), 0);
      EXPECT_EQ(m.cycle, expected_cycle++);
      ++cycles;
    } else if (ev->channel == "FTID_WRENCH") {
      ++wrenches;
    } else if (ev->channel == "FTID_STATS") {
      ++stats;
    }
  }
  EXPECT_EQ(cycles, 25);
  EXPECT_EQ(wrenches, 25);
  EXPECT_EQ(stats, 1);
  std::remove(path.c_str());
}

TEST(LcmOutbox, DispatchesCommandsOnItsThread) {
  lcm::LCM lc("memq://");
  LcmOutbox outbox(OutboxOptions{}, &lc);
  SeenCommands seen;
  outbox.setCommandHandler(&SeenCommands::record, &seen);
  outbox.start();
  // memq delivers on the next handle() of the instance; the outbox thread handles it.
  publishCommand(lc, 77);
  EXPECT_TRUE(waitForCommands(seen, 1));
  outbox.stop();
  EXPECT_EQ(seen.count.load(), 1);
  EXPECT_EQ(seen.id.load(), 77);
  EXPECT_EQ(outbox.counters().commands, 1u);
}

// The shared instance outlives the outbox: after stop() (and after destruction) a command
// handled on it must not reach the outbox any more (before the fix the subscription stayed, so
// this dispatched into a stopped, then freed, outbox).
TEST(LcmOutbox, StopUnsubscribesTheCommandHandlerFromASharedInstance) {
  lcm::LCM lc("memq://");
  std::atomic<int> delivered{0};
  lc.subscribeFunction("FTID_COMMAND", &countCommand, &delivered);
  SeenCommands seen;
  {
    LcmOutbox outbox(OutboxOptions{}, &lc);
    outbox.setCommandHandler(&SeenCommands::record, &seen);
    outbox.start();
    outbox.stop();
    publishCommand(lc, 1);
    while (lc.handleTimeout(0) > 0) {
    }
    EXPECT_EQ(delivered.load(), 1);
    EXPECT_EQ(seen.count.load(), 0);
    EXPECT_EQ(outbox.counters().commands, 0u);
  }
  publishCommand(lc, 2);
  while (lc.handleTimeout(0) > 0) {
  }
  EXPECT_EQ(delivered.load(), 2);
  EXPECT_EQ(seen.count.load(), 0);
}

// stop() then start() again subscribes once, not twice: each command is dispatched once.
TEST(LcmOutbox, RestartDispatchesEachCommandOnce) {
  lcm::LCM lc("memq://");
  LcmOutbox outbox(OutboxOptions{}, &lc);
  SeenCommands seen;
  outbox.setCommandHandler(&SeenCommands::record, &seen);
  outbox.start();
  outbox.stop();
  outbox.start();
  publishCommand(lc, 5);
  EXPECT_TRUE(waitForCommands(seen, 1));
  outbox.stop();  // joins the thread: every handler of that message has run
  EXPECT_EQ(seen.count.load(), 1);
  EXPECT_EQ(outbox.counters().commands, 1u);
}

TEST(LcmOutbox, RejectsOverlongChannelAndBadUrl) {
  OutboxOptions opt;
  opt.url = "memq://";
  opt.channels.wrench = std::string(64, 'W');
  EXPECT_THROW(LcmOutbox{opt}, ConfigError);
  OutboxOptions bad;
  bad.url = "nosuchprovider://x";
  EXPECT_THROW(LcmOutbox{bad}, DriverError);
}

}  // namespace
}  // namespace ftid::transport
