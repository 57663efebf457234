// Real-time safety of ftidd's TARE on the loop side: a DaemonCycle with the production
// compensation taking a tare request from its mailbox, accumulating the window (TareAccumulator)
// and writing the result to the other mailbox, plus refused windows (robot moving), all under the
// allocation counter.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <memory>

#include "../unit/daemon/fakes.hpp"
#include "alloc_controls.hpp"
#include "alloc_counter.hpp"
#include "ftid/daemon/adapters.hpp"
#include "ftid/daemon/daemon_cycle.hpp"
#include "ftid/daemon/tare.hpp"

FTID_ALLOCATION_COUNTER_CONTROLS();

namespace ftid::daemon {
namespace {

TEST(RtTare, WindowAccumulationAndHandOverDoNotAllocate) {
  const std::string path = ::testing::TempDir() + "ftid_rt_tare_" + std::to_string(::getpid()) + ".yaml";
  struct RemoveOnExit {
    std::string p;
    ~RemoveOnExit() {
      std::remove(p.c_str());
      std::remove((p + ".bak").c_str());
    }
  } remove_on_exit{path};
  params::ParameterSet set;
  set.model = "paper";
  for (int i = 0; i < 6; ++i) set.params.push_back({kOffsetNames[i], 0.1 * (i + 1), 0.0, ""});
  set.params.push_back({"mass", 1.2, 0.0, "kg"});
  set.params.push_back({"mass_com_x", 0.01, 0.0, "kg*m"});
  set.params.push_back({"mass_com_y", -0.02, 0.0, "kg*m"});
  set.params.push_back({"mass_com_z", 0.07, 0.0, "kg*m"});
  params::writeParameterFile(path, set);

  rt::OwnedSwapSlot<Compensation> slot(std::make_unique<ParameterFileCompensation>(path));
  test::FakeArm arm;
  test::FakeSensor sensor;
  test::FixedMotion motion;
  test::RecordingSink sink;
  sensor.sample.wrench_S << 1, 2, -9, 0.1, 0.2, 0.3;
  CycleOptions opt;
  opt.now_us = &test::fakeNowUs;
  DaemonCycle cycle(&arm, &sensor, &motion, &slot, &sink, opt);
  rt::Mailbox<TareRequest> requests;
  rt::Mailbox<TareResult> results;
  cycle.attachTare(&requests, &results);
  auto tick = [&] {
    test::g_fake_now_us += 8000;
    ASSERT_EQ(cycle.waitForTick(std::chrono::milliseconds(12)), Status::kOk);
    cycle.onTick();
  };
  tick();  // warm-up outside the counter
  TareRequest req;
  req.cycles = 30;
  TareResult ok{};
  TareResult moving{};
  std::size_t allocations = 0;
  {
    ftid::test::ScopedAllocationCounter counter;
    req.id = 1;
    requests.tryPush(req);
    for (int i = 0; i < 30; ++i) tick();
    results.tryPop(&ok);
    req.id = 2;
    requests.tryPush(req);
    tick();
    arm.state.qd(0) = 0.5;
    tick();
    results.tryPop(&moving);
    allocations = counter.count();
  }
  EXPECT_EQ(allocations, 0u);
  EXPECT_EQ(ok.id, 1u);
  EXPECT_EQ(ok.outcome, TareOutcome::kOk);
  EXPECT_EQ(ok.cycles, 30u);
  EXPECT_EQ(moving.id, 2u);
  EXPECT_EQ(moving.outcome, TareOutcome::kMoving);
}

}  // namespace
}  // namespace ftid::daemon
