// Real-time safety of ftidd's loop side: one whole DaemonCycle step with the production
// kinematics, the production compensation (paper+rigid_body model from a parameter file) and the
// production sink (LcmOutbox::tryPush), a parameter swap, and the transport codec, all under the
// allocation counter.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <map>

#include <lcm/lcm-cpp.hpp>

#include "../unit/daemon/fakes.hpp"
#include "alloc_counter.hpp"
#include "ftid/daemon/adapters.hpp"
#include "ftid/daemon/daemon_cycle.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/identify/parameter_set.hpp"
#include "ftid/transport/codec.hpp"
#include "ftid/transport/lcm_outbox.hpp"
#include "ftid/transport/spsc_queue.hpp"

namespace ftid::daemon {
namespace {

std::string writeParams(const std::string& model_name, const std::string& path, double mass) {
  const effects::Model model = effects::Model::fromName(model_name);
  identify::ParameterSet set;
  set.model = model.name();
  double k = 0.01;
  for (const auto& name : model.paramIndex().names()) {
    set.params.push_back({name, name == "mass" ? mass : k, 0.0, ""});
    k += 0.01;
  }
  set.tilt_u_rad = 0.01;
  set.tilt_v_rad = -0.02;
  identify::writeParameterFile(path, set);
  return path;
}

TEST(RtDaemon, CycleStepWithProductionMathAndSinkDoesNotAllocate) {
  const std::string dir = ::testing::TempDir() + "ftid_rt_daemon_" + std::to_string(::getpid());
  const std::string p1 = writeParams("paper+rigid_body", dir + "_a.yaml", 1.5);
  const std::string p2 = writeParams("paper", dir + "_b.yaml", 2.5);

  model::RobotKinematics kin = model::RobotKinematics::fromUrdfFile(FTID_SOURCE_DIR "/config/ur10.urdf");
  KinematicsMotionModel motion(kin);
  OwnedSwapSlot<Compensation> slot(std::make_unique<ParameterFileCompensation>(p1));
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
  std::remove(p1.c_str());
  std::remove(p2.c_str());
}

TEST(RtDaemon, CodecAndQueueDoNotAllocate) {
  transport::warmUpCodec();
  transport::CycleRecord rec;
  rec.sensor.wrench_S << 1, 2, 3, 4, 5, 6;
  ftid_lcm::cycle_sample_t cycle_msg{};
  ftid_lcm::compensated_wrench_t wrench_msg{};
  std::uint8_t buf[2048];
  static transport::SpscQueue<transport::CycleRecord, 64> queue;
  transport::CycleRecord out;
  std::size_t allocations = 0;
  {
    ftid::test::ScopedAllocationCounter counter;
    transport::toLcm(rec, &cycle_msg);
    transport::toLcm(rec, &wrench_msg);
    EXPECT_GT(transport::encodeInto(cycle_msg, buf, sizeof buf), 0);
    EXPECT_GT(transport::encodeInto(wrench_msg, buf, sizeof buf), 0);
    EXPECT_TRUE(transport::decodeFrom(buf, sizeof buf, &wrench_msg));
    EXPECT_TRUE(queue.tryPush(rec));
    EXPECT_TRUE(queue.tryPop(&out));
    allocations = counter.count();
  }
  EXPECT_EQ(allocations, 0u);
  EXPECT_EQ(out.sensor.wrench_S, rec.sensor.wrench_S);
}

}  // namespace
}  // namespace ftid::daemon
