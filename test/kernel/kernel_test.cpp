// Tests that need the real kernel features of the target machine: AF_CAN with a vcan0 interface
// and a PREEMPT_RT kernel. They run only inside scripts/kernel-rig.sh (Debian's PREEMPT_RT kernel
// booted in qemu, docs/kernel-rig.md); there a missing feature is a failure, never a skip. One
// executable, ftid_kernel_test, of two sources: this one, the kernel features, and
// kernel_ftidd_test.cpp, ftidd end to end on them.
//
//   PreemptRt.*         the kernel is PREEMPT_RT; SCHED_FIFO, mlockall and /dev/cpu_dma_latency
//                       succeed with require = true and a timer-clocked loop runs (no timing is
//                       asserted: qemu's TCG does not emulate real time).
//   SocketCanSensor.*   the simulator's frame source -> a raw AF_CAN socket on vcan0 -> the
//                       daemon's sensor driver (endpoint socketcan:vcan0): the injected faults have
//                       the same effects as on the SOCK_SEQPACKET stand-in (sim_sensor_test.cpp,
//                       FrameSourceTest.InjectedFaultsShowUpInTheFrames).
#include <gtest/gtest.h>

#include <sched.h>
#include <sys/utsname.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "ftid/common/error.hpp"
#include "ftid/common/status.hpp"
#include "ftid/drivers/can/ft_imu_sensor.hpp"
#include "ftid/drivers/can/socketcan.hpp"
#include "ftid/rt/cyclic_executor.hpp"
#include "ftid/rt/rt_setup.hpp"
#include "ftid/rt/rt_thread.hpp"
#include "ftid/simsensor/sim_sensor.hpp"
#include "kernel_test_support.hpp"

namespace ftid {
namespace {

using kerneltest::homeQ;
using kerneltest::kIface;
using kerneltest::kSrc;
using kerneltest::requireVcan;
using kerneltest::slurp;

// ---- PREEMPT_RT ------------------------------------------------------------------------------

TEST(PreemptRt, KernelIsPreemptRt) {
  utsname u{};
  ASSERT_EQ(uname(&u), 0);
  EXPECT_NE(std::string(u.version).find("PREEMPT_RT"), std::string::npos) << u.version;
  EXPECT_EQ(slurp("/sys/kernel/realtime").substr(0, 1), "1");
  EXPECT_TRUE(rt::hasRealtimeKernel());
}

struct CountingCycle {
  int cycles = 0;
  int limit = 0;
  rt::CycleAction onTimer(std::int64_t /*deadline_ns*/) noexcept {
    return ++cycles >= limit ? rt::CycleAction::kStop : rt::CycleAction::kContinue;
  }
};

TEST(PreemptRt, RealtimeSetUpSucceedsAndTheLoopRuns) {
  rt::RealtimeConfig cfg;
  cfg.require = true;  // any failure throws RealtimeSetupError
  cfg.priority = 80;
  cfg.cpu = sysconf(_SC_NPROCESSORS_ONLN) > 1 ? 1 : 0;
  cfg.lock_memory = true;
  cfg.dma_latency = true;
  int policy = -1;
  int priority = -1;
  int cpu = -1;
  std::string dma_value;
  rt::LoopStats stats;
  rt::LoopExit exit = rt::LoopExit::kDeviceFault;
  CountingCycle cycle;
  cycle.limit = 500;
  rt::RealtimeReport report;
  ASSERT_NO_THROW(report = rt::runInRealtimeThread(cfg, [&] {
    sched_param sp{};
    policy = sched_getscheduler(0);
    if (sched_getparam(0, &sp) == 0) priority = sp.sched_priority;
    cpu = sched_getcpu();
    rt::ExecutorConfig ec;
    ec.period = std::chrono::milliseconds(1);
    exit = rt::runTimerClocked(cycle, ec, &stats);
  }));
  std::string problems;
  for (const auto& p : report.problems) problems += p + "; ";
  EXPECT_TRUE(report.problems.empty()) << problems;
  EXPECT_TRUE(report.realtime_kernel);
  EXPECT_TRUE(report.memory_locked);
  EXPECT_TRUE(report.fifo);
  EXPECT_TRUE(report.pinned);
  EXPECT_TRUE(report.dma_latency);
  EXPECT_EQ(policy, SCHED_FIFO);
  EXPECT_EQ(priority, 80);
  EXPECT_EQ(cpu, cfg.cpu);
  // mlockall(MCL_CURRENT | MCL_FUTURE) is in effect for this process.
  const std::string status = slurp("/proc/self/status");
  const auto at = status.find("VmLck:");
  ASSERT_NE(at, std::string::npos);
  EXPECT_GT(std::atol(status.c_str() + at + 6), 0L) << status.substr(at, 40);
  // The loop ran every cycle and stopped itself; its latency is not asserted (TCG).
  EXPECT_EQ(exit, rt::LoopExit::kCycleStopped);
  EXPECT_EQ(cycle.cycles, 500);
  EXPECT_EQ(stats.cycles, 500u);
  RecordProperty("wakeup_p99_us_tcg", static_cast<int>(stats.wakeup.quantileNs(0.99) / 1000));
}

// ---- the sensor driver on real AF_CAN --------------------------------------------------------

TEST(SocketCanSensor, InjectedFaultsArriveOverVcanAsOnTheStandIn) {
  requireVcan();
  if (HasFatalFailure()) return;
  using simsensor::SensorFault;
  const drivers::can::SensorLayout layout =
      drivers::can::SensorLayout::fromDbc(drivers::can::loadDbc(kSrc + "/config/ftsensor.dbc"));
  simsensor::SimSensorConfig config = simsensor::defaultSimSensorConfig();
  config.cell.temperature_drift.enabled = false;
  simsensor::RobotHistory history;
  for (int k = 0; k < 4; ++k) {
    simsensor::RobotHistory::Tick t;
    t.t = 50.0 + 0.008 * k;
    t.q = homeQ();
    history.add(t);
  }
  simsensor::SensorFrameSource src(config, layout,
                                   model::RobotKinematics::fromUrdfFile(kSrc + "/config/ur10.urdf"));
  // The sender: a plain raw socket on vcan0, as `ftid sim-sensor --can-interface` opens it.
  drivers::can::SocketCanOptions tx_opts;
  tx_opts.interface = kIface;
  tx_opts.error_mask = 0;
  drivers::can::SocketCanTransport bus(tx_opts);
  // The receiver: the daemon's driver, opened from its endpoint string.
  drivers::can::CanSensorConfig sc;
  sc.endpoint = std::string("socketcan:") + kIface;
  sc.dbc_path = kSrc + "/config/ftsensor.dbc";
  sc.health.stale_timeout_ns = 3'500'000;  // 3.5 samples at 1 kHz, as on the stand-in
  auto sensor = drivers::can::openCanSensor(sc);

  std::array<can_frame, simsensor::SensorFrameSource::kMaxFrames> frames{};
  std::uint64_t sent = 0;
  drivers::can::SensorSample s;
  // One sensor sample: its frames go out on vcan0; the driver reads until it has received all of
  // them (the kernel delivers asynchronously). Reads in between may report part of the step's
  // flags, so the step's flags are the union over its reads; `s` is the last read. The stale
  // check is not exercised here (now = 0); it is tested with explicit silence below.
  std::uint32_t step_flags = 0;
  const auto step = [&]() {
    const int n = src.nextSample(history, 50.03, 1.0, frames);
    for (int i = 0; i < n; ++i) {
      EXPECT_EQ(bus.trySend(frames[static_cast<std::size_t>(i)]), drivers::can::IoResult::kOk)
          << "errno " << bus.lastErrno();
    }
    sent += static_cast<std::uint64_t>(n);
    step_flags = 0;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    do {
      sensor->tryReadLatest(s, 0);
      step_flags |= s.health_flags;
      if (sensor->health().frames_received >= sent) break;
      sensor->transport().waitReadable(std::chrono::milliseconds(20));
    } while (std::chrono::steady_clock::now() < deadline);
    EXPECT_EQ(sensor->health().frames_received, sent) << "frames lost on vcan0";
    return n;
  };
  for (int i = 0; i < 5; ++i) EXPECT_EQ(step(), 6);
  EXPECT_TRUE(s.valid);
  EXPECT_NE(s.rx_time_ns, 0);  // the kernel's receive timestamp (SO_TIMESTAMPNS)

  src.inject(SensorFault::kSilent, 5);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(step(), 0);
  sensor->tryReadLatest(s, s.rx_time_ns + 5'000'000);  // 5 ms without a sample
  EXPECT_FALSE(s.valid);  // stale after 3.5 ms of silence
  EXPECT_TRUE(s.health_flags & kHealthStale);
  step();
  EXPECT_TRUE(s.valid);
  EXPECT_TRUE(step_flags & kHealthCounterGap);
  EXPECT_EQ(sensor->health().samples_lost, 5u);

  src.inject(SensorFault::kCounterGap, 7);
  step();
  EXPECT_EQ(sensor->health().samples_lost, 12u);

  src.inject(SensorFault::kOutOfRange, 2);
  step();
  EXPECT_FALSE(s.valid);
  EXPECT_TRUE(s.health_flags & kHealthOutOfRange);
  EXPECT_NEAR(s.wrench_S[0], 360.0, 0.03);
  step();
  step();
  EXPECT_TRUE(s.valid);

  src.inject(SensorFault::kStuckCounter, 1);
  step();
  step();
  EXPECT_TRUE(step_flags & kHealthCounterRepeat);
  EXPECT_FALSE(s.valid);
  step();
  EXPECT_TRUE(s.valid);

  src.inject(SensorFault::kStatusFault, 1);
  step();
  EXPECT_FALSE(s.valid);
  EXPECT_EQ(s.status_word, 0x2u);

  // Error frames (CAN_ERR_FLAG) cross vcan0 and reach the driver through its CAN_RAW_ERR_FILTER.
  src.inject(SensorFault::kErrorFrame, 2);
  EXPECT_EQ(step(), 8);
  EXPECT_EQ(sensor->health().error_frames, 2u);
  EXPECT_TRUE(step_flags & kHealthErrorFrame);
  src.inject(SensorFault::kBusOff, 1);
  step();
  EXPECT_EQ(sensor->health().bus_off_events, 1u);
  EXPECT_EQ(sensor->health().samples_incomplete, 0u);
  EXPECT_EQ(sensor->health().frames_malformed, 0u);
}

// On a kernel WITH AF_CAN the set-up errors still name what is wrong (the converse of
// SocketCan.ConstructorExplainsMissingSupport, which runs where AF_CAN is missing).
TEST(SocketCanSensor, UnknownInterfaceIsNamedInTheError) {
  requireVcan();
  if (HasFatalFailure()) return;
  drivers::can::SocketCanOptions o;
  o.interface = "vcan9";
  try {
    drivers::can::SocketCanTransport t(o);
    FAIL() << "opened a socket on a missing interface";
  } catch (const DriverError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("socketcan:vcan9"), std::string::npos) << what;
    EXPECT_NE(what.find("no such network interface"), std::string::npos) << what;
  }
  drivers::can::CanSensorConfig sc;
  sc.endpoint = "socketcan:vcan9";
  sc.dbc_path = kSrc + "/config/ftsensor.dbc";
  EXPECT_THROW(drivers::can::openCanSensor(sc), DriverError);
}

}  // namespace
}  // namespace ftid
