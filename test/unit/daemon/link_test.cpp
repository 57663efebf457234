// ftidd's links (docs/operations.md, "Link loss and reconnect"):
//  - Backoff: the delays between connection attempts start at min_s, grow by the factor and never
//    leave [min_s, max_s] (written out by hand for the default policy, and for seeded random
//    policies against the closed form min(min_s * factor^k, max_s));
//  - LoopOwner: a robot connection that fails (kFault) or stays silent ends the loop's session;
//    the link thread reconnects with that backoff and the same DaemonCycle resumes: the cycle
//    numbers continue without a restart, the parameters are the same object, the outage and the
//    reconnect are counted; the loop thread's heartbeat advances while it is parked; stop()
//    returns promptly during a long backoff;
//  - CanSensorSource: a sensor transport whose peer went away is flagged down, a reopened one is
//    taken by the next drain and samples resume.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "fakes.hpp"
#include "ftid/common/error.hpp"
#include "ftid/daemon/adapters.hpp"
#include "ftid/daemon/backoff.hpp"
#include "ftid/daemon/loop_owner.hpp"
#include "ftid/daemon/output_stage.hpp"
#include "ftid/drivers/can/seqpacket.hpp"
#include "systemd_notify.hpp"  // src/daemon (private header)
#include "test_paths.hpp"

namespace ftid::daemon {
namespace {

using namespace std::chrono_literals;
using test::FakeSensor;
using test::FixedMotion;
using test::OffsetCompensation;
using test::RecordingSink;

double seconds(std::chrono::nanoseconds d) { return static_cast<double>(d.count()) * 1e-9; }

// ------------------------------------------------------------------------------------ Backoff
TEST(Backoff, DefaultPolicyDoublesFromMinToMaxAndResets) {
  Backoff b({0.2, 5.0, 2.0});
  const double expected[] = {0.2, 0.4, 0.8, 1.6, 3.2, 5.0, 5.0, 5.0};
  for (double e : expected) EXPECT_NEAR(seconds(b.next()), e, 1e-9);
  EXPECT_EQ(b.attempts(), 8u);
  b.reset();
  EXPECT_EQ(b.attempts(), 0u);
  EXPECT_NEAR(seconds(b.next()), 0.2, 1e-9);
}

TEST(Backoff, EveryDelayIsWithinTheBoundsAndFollowsTheClosedForm) {
  std::mt19937 rng(20261202);
  std::uniform_real_distribution<double> min_s(0.001, 2.0), span(1.0, 50.0), factor(1.0, 4.0);
  for (int trial = 0; trial < 200; ++trial) {
    BackoffPolicy p;
    p.min_s = min_s(rng);
    p.max_s = p.min_s * span(rng);
    p.factor = factor(rng);
    Backoff b(p);
    double prev = 0.0;
    for (int k = 0; k < 40; ++k) {
      const double d = seconds(b.next());
      const double closed = std::min(p.min_s * std::pow(p.factor, k), p.max_s);
      ASSERT_NEAR(d, closed, 1e-9 + 1e-12 * closed) << "trial " << trial << " k " << k;
      ASSERT_GE(d, p.min_s - 1e-9);
      ASSERT_LE(d, p.max_s + 1e-9);
      ASSERT_GE(d, prev - 1e-9);
      prev = d;
    }
  }
}

TEST(Backoff, NonsensePoliciesAreClampedIntoBounds) {
  Backoff zero({0.0, 0.0, 0.5});  // min 0, max below min, shrinking factor
  for (int k = 0; k < 5; ++k) EXPECT_NEAR(seconds(zero.next()), 1e-3, 1e-12);
  Backoff nan({std::nan(""), 1.0, std::nan("")});
  EXPECT_NEAR(seconds(nan.next()), 1e-3, 1e-12);
  EXPECT_NEAR(seconds(nan.next()), 1e-3, 1e-12);  // factor NaN -> 1
  Backoff inverted({2.0, 1.0, 2.0});
  EXPECT_NEAR(seconds(inverted.next()), 2.0, 1e-12);
  EXPECT_NEAR(seconds(inverted.next()), 2.0, 1e-12);
}

// --------------------------------------------------------------------------------- LoopOwner
/// A robot connection: `states` state packages 1 ms apart, then either a fault (connection lost)
/// or silence (timeouts), as scripted. robot_time continues across connections (one controller).
class ScriptedArm : public ArmStateSource {
 public:
  enum class Then { kFault, kSilence, kStream };
  ScriptedArm(int states, Then then, double* robot_time) : left_(states), then_(then), t_(robot_time) {}
  Status waitForState(std::chrono::nanoseconds timeout,
                      RobotStateRecord* out) noexcept override {
    if (left_ == 0 && then_ == Then::kFault) return Status::kFault;
    if (left_ == 0 && then_ == Then::kSilence) {
      std::this_thread::sleep_for(timeout);
      return Status::kTimeout;
    }
    if (left_ > 0) --left_;
    std::this_thread::sleep_for(1ms);
    // The controller's clock: 1 ms per package, or (real_time) the host clock itself, so that the
    // sensor pairing maps each state to about its receive time.
    *t_ = real_time ? static_cast<double>(realtimeNowUs() - 1'700'000'000'000'000) * 1e-6 : *t_ + 0.001;
    out->valid = true;
    out->robot_time = *t_;
    out->recv_utime = realtimeNowUs();
    out->q.setZero();
    out->qd.setZero();
    out->qdd.setZero();
    return Status::kOk;
  }
  const char* lastError() const noexcept override { return "scripted: link cut"; }
  bool real_time = false;

 private:
  int left_;
  Then then_;
  double* t_;
};

struct Rig {
  double robot_time = 50.0;
  FakeSensor sensor{&monotonicNowUs};  // the cycle's clocks are the real ones (CycleOptions{})
  FixedMotion motion;
  rt::OwnedSwapSlot<Compensation> params{std::make_unique<OffsetCompensation>(Wrench::Zero())};
  RecordingSink sink;
  DaemonCycle cycle{nullptr, &sensor, &motion, &params, &sink, CycleOptions{}};
  rt::LoopStats stats;
  std::mutex log_mutex;
  std::vector<std::string> log;
  std::atomic<int> connects{0};

  LoopOwnerOptions options(double backoff_min_s, double backoff_max_s) {
    LoopOwnerOptions o;
    o.rt.enable = false;  // a plain thread: no real-time privileges needed here
    o.exec.period = 1ms;
    o.exec.timeout_periods = 5.0;
    o.exec.max_consecutive_missed = 0xFFFFFFFFu;
    o.backoff = {backoff_min_s, backoff_max_s, 2.0};
    o.robot_name = "scripted:1";
    o.tick = 10ms;
    return o;
  }
  LoopOwner::Log logger() {
    return [this](const std::string& line) {
      std::lock_guard<std::mutex> l(log_mutex);
      log.push_back(line);
    };
  }
  bool logged(const std::string& part) {
    std::lock_guard<std::mutex> l(log_mutex);
    return std::any_of(log.begin(), log.end(),
                       [&](const std::string& s) { return s.find(part) != std::string::npos; });
  }
};

template <class Pred>
bool waitFor(Pred pred, std::chrono::milliseconds limit) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < end) {
    if (pred()) return true;
    std::this_thread::sleep_for(2ms);
  }
  return pred();
}

TEST(LoopOwner, ReconnectsWithBackoffAfterAFaultAndTheSameCycleResumes) {
  Rig rig;
  // Two failed attempts (controller still booting), then a connection that streams.
  ArmConnector connect = [&rig]() -> std::unique_ptr<ArmStateSource> {
    if (++rig.connects <= 2) throw DriverError("RTDE scripted:1: connection refused");
    return std::make_unique<ScriptedArm>(1'000'000, ScriptedArm::Then::kStream, &rig.robot_time);
  };
  Compensation* params_before = rig.params.current();
  LoopOwner owner(&rig.cycle, &rig.stats, connect, SensorLink{}, rig.options(0.05, 0.5), rig.logger());
  owner.start(std::make_unique<ScriptedArm>(40, ScriptedArm::Then::kFault, &rig.robot_time));

  ASSERT_TRUE(waitFor([&] { return owner.status().robot_reconnects == 1; }, 5000ms));
  ASSERT_TRUE(waitFor([&] { return rig.cycle.counters().cycles.load() >= 80; }, 5000ms));
  const LinkStatus st = owner.status();
  owner.stop();

  EXPECT_EQ(rig.connects.load(), 3);
  EXPECT_TRUE(st.robot_up);
  EXPECT_EQ(st.robot_attempts, 2u);  // the failed attempts of the outage
  // Backoff after each failed attempt: 0.05 s, then 0.1 s.
  EXPECT_GE(st.robot_down_total_s, 0.15 - 0.01);
  EXPECT_LT(st.robot_down_total_s, 2.0);
  EXPECT_EQ(st.robot_down_current_s, 0.0);
  // The same cycle resumed: numbering continues (no restart at 0), the same parameters.
  const int n = rig.sink.count;
  ASSERT_GE(n, 80);
  for (int i = 0; i < n; ++i) ASSERT_EQ(rig.sink.records[static_cast<std::size_t>(i)].cycle, i);
  EXPECT_EQ(rig.params.current(), params_before);
  EXPECT_EQ(rig.params.version(), 1u);
  EXPECT_TRUE(rig.logged("lost: the connection failed (scripted: link cut)"));
  EXPECT_TRUE(rig.logged("connection refused"));
  EXPECT_TRUE(rig.logged("restored after"));
}

// ftidd started before the controller (docs/daemon.md, "Running"): no first connection; the link
// thread connects with the backoff while the loop is parked, then the loop starts. The first
// connection is not a reconnect.
TEST(LoopOwner, StartedWithoutARobotConnectsWithBackoffAndTheLoopStarts) {
  Rig rig;
  ArmConnector connect = [&rig]() -> std::unique_ptr<ArmStateSource> {
    if (++rig.connects <= 3) throw DriverError("RTDE scripted:1: connection refused");
    return std::make_unique<ScriptedArm>(1'000'000, ScriptedArm::Then::kStream, &rig.robot_time);
  };
  LoopOwner owner(&rig.cycle, &rig.stats, connect, SensorLink{}, rig.options(0.05, 0.5), rig.logger());
  owner.start(nullptr);
  const LinkStatus down = owner.status();
  EXPECT_FALSE(down.robot_up);
  EXPECT_FALSE(down.robot_ever_up);
  ASSERT_TRUE(waitFor([&] { return owner.loopHeartbeat() > 0; }, 2000ms));  // parked, alive
  EXPECT_EQ(rig.cycle.counters().cycles.load(), 0u);
  ASSERT_TRUE(waitFor([&] { return rig.cycle.counters().cycles.load() >= 50; }, 5000ms));
  const LinkStatus st = owner.status();
  owner.stop();
  EXPECT_EQ(rig.connects.load(), 4);
  EXPECT_TRUE(st.robot_up);
  EXPECT_TRUE(st.robot_ever_up);
  EXPECT_EQ(st.robot_reconnects, 0);  // the first connection is not a reconnect
  EXPECT_EQ(st.robot_attempts, 3u);
  // Backoff after each failed attempt: 0.05 + 0.1 + 0.2 s.
  EXPECT_GE(st.robot_down_total_s, 0.35 - 0.01);
  EXPECT_TRUE(rig.logged("no robot link to scripted:1 yet"));
  EXPECT_TRUE(rig.logged("robot connection attempt 1 failed: RTDE scripted:1: connection refused"));
  EXPECT_TRUE(rig.logged("robot link to scripted:1 up after"));
  EXPECT_FALSE(rig.logged("restored"));
}

TEST(LoopOwner, ASilentConnectionIsRenewedAfterTheSilenceLimit) {
  Rig rig;
  ArmConnector connect = [&rig]() -> std::unique_ptr<ArmStateSource> {
    ++rig.connects;
    return std::make_unique<ScriptedArm>(1'000'000, ScriptedArm::Then::kStream, &rig.robot_time);
  };
  LoopOwnerOptions o = rig.options(0.01, 0.1);
  o.exec.max_consecutive_missed = 20;  // 20 receive timeouts of 5 ms: 0.1 s of silence
  LoopOwner owner(&rig.cycle, &rig.stats, connect, SensorLink{}, o, rig.logger());
  owner.start(std::make_unique<ScriptedArm>(30, ScriptedArm::Then::kSilence, &rig.robot_time));
  ASSERT_TRUE(waitFor([&] { return owner.status().robot_reconnects == 1; }, 5000ms));
  ASSERT_TRUE(waitFor([&] { return rig.cycle.counters().cycles.load() >= 60; }, 5000ms));
  owner.stop();
  EXPECT_EQ(rig.connects.load(), 1);
  EXPECT_GE(rig.cycle.counters().missed.load(), 20u);
  EXPECT_TRUE(rig.logged("no state package for 0.1 s although the connection is up"));
}

TEST(LoopOwner, WhileReconnectingTheLoopIsParkedButAliveAndStopIsPrompt) {
  Rig rig;
  ArmConnector never = [&rig]() -> std::unique_ptr<ArmStateSource> {
    ++rig.connects;
    throw DriverError("RTDE scripted:1: no route to host");
  };
  LoopOwner owner(&rig.cycle, &rig.stats, never, SensorLink{}, rig.options(0.02, 10.0), rig.logger());
  owner.start(std::make_unique<ScriptedArm>(5, ScriptedArm::Then::kFault, &rig.robot_time));
  ASSERT_TRUE(waitFor([&] { return rig.connects.load() >= 3; }, 5000ms));
  const std::uint64_t cycles = rig.cycle.counters().cycles.load();
  const std::uint64_t beat = owner.loopHeartbeat();
  std::this_thread::sleep_for(100ms);
  EXPECT_EQ(rig.cycle.counters().cycles.load(), cycles);  // no cycle without a connection
  EXPECT_GT(owner.loopHeartbeat(), beat);                 // but the loop thread is alive
  EXPECT_TRUE(owner.linkThreadAlive(1s));
  const LinkStatus st = owner.status();
  EXPECT_FALSE(st.robot_up);
  EXPECT_GT(st.robot_down_current_s, 0.0);
  EXPECT_GE(st.robot_attempts, 3u);
  EXPECT_NE(st.robot_last_error.find("no route to host"), std::string::npos);
  // The backoff has grown towards 10 s; stop() must not wait for it.
  std::this_thread::sleep_for(300ms);
  const auto t0 = std::chrono::steady_clock::now();
  owner.stop();
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 500ms);
  std::string why;
  EXPECT_FALSE(owner.loopFailed(&why));
  // One log line per distinct reason, not one per attempt.
  std::lock_guard<std::mutex> l(rig.log_mutex);
  EXPECT_EQ(std::count_if(rig.log.begin(), rig.log.end(),
                          [](const std::string& s) { return s.find("no route to host") != std::string::npos; }),
            1);
}

TEST(LoopOwner, ANewConnectionRestartsTheOutputLowPassAtTheFirstValidWrench) {
  Rig rig;
  OutputStageConfig oc;
  oc.lowpass_hz = 5.0;
  oc.sample_rate_hz = 1000.0;
  OutputStage stage(oc);
  rig.cycle.attachOutputStage(&stage);
  ScriptedArm first(1'000'000, ScriptedArm::Then::kStream, &rig.robot_time);
  ScriptedArm second(1'000'000, ScriptedArm::Then::kStream, &rig.robot_time);
  first.real_time = second.real_time = true;
  auto tick = [&] {
    ASSERT_EQ(rig.cycle.waitForTick(5ms), Status::kOk);
    rig.cycle.onTick();
  };
  rig.cycle.setArm(&first);
  rig.sensor.sample.wrench_S << 0, 0, -10, 0, 0, 0;
  for (int i = 0; i < 20; ++i) tick();
  const double settled = rig.cycle.lastRecord().output(2);
  EXPECT_NEAR(settled, -10.0, 1e-9);  // a primed filter starts at its first value
  rig.sensor.sample.wrench_S << 0, 0, -30, 0, 0, 0;  // the contact changed during the outage
  std::this_thread::sleep_for(5ms);
  rig.cycle.setArm(&second);
  tick();
  // The first valid wrench of the new connection is output as it is (the filter restarted), not
  // a filtered mix with the -10 N before the outage.
  ASSERT_TRUE(rig.cycle.lastRecord().wrench_valid);
  EXPECT_NEAR(rig.cycle.lastRecord().contact_S(2), -30.0, 1e-9);
  EXPECT_NEAR(rig.cycle.lastRecord().output(2), rig.cycle.lastRecord().contact_S(2), 1e-9);
}

// The watchdog decision: a wedged loop or link thread is never fed; a silent robot only if
// robot.watchdog_silence_s says so.
TEST(Watchdog, FedOnlyWhileEveryThreadProgressesAndTheSilenceLimitAllows) {
  // Default (0 = never stop for the link): renewing the link for an hour stays fed.
  EXPECT_TRUE(watchdogMayBeFed(true, true, 3600.0, 0.0));
  EXPECT_TRUE(watchdogMayBeFed(true, true, 0.0, 0.0));
  // A wedged loop thread (no cycle, no missed wait, no parked wake-up) or a stuck reconnect.
  EXPECT_FALSE(watchdogMayBeFed(false, true, 0.0, 0.0));
  EXPECT_FALSE(watchdogMayBeFed(true, false, 0.0, 0.0));
  EXPECT_FALSE(watchdogMayBeFed(false, false, 0.0, 30.0));
  // With a silence limit: fed below it, not at or beyond it.
  EXPECT_TRUE(watchdogMayBeFed(true, true, 0.99, 1.0));
  EXPECT_FALSE(watchdogMayBeFed(true, true, 1.0, 1.0));
  EXPECT_FALSE(watchdogMayBeFed(true, true, 5.0, 1.0));
}

// --------------------------------------------------------------------------- CanSensorSource
struct SensorBench {
  std::string path = ::testing::TempDir() + "ftid_link_sensor_" + std::to_string(::getpid()) + ".sock";
  drivers::can::SensorLayout layout =
      drivers::can::SensorLayout::fromDbc(drivers::can::loadDbc(ftid::test::sourcePath("/config/ftsensor.dbc")));
  std::unique_ptr<drivers::can::SeqpacketCanServer> server = std::make_unique<drivers::can::SeqpacketCanServer>(path);
  CanSensorSource source{
      std::make_unique<drivers::can::CanFtImuSensor>(std::make_unique<drivers::can::SeqpacketCanClient>(path), layout),
      drivers::can::SensorHealthOptions{}};
  SensorHistory history;
  SensorSampleRecord latest;

  void send(std::uint32_t counter, double fz) {
    std::array<can_frame, drivers::can::SensorLayout::kMaxMessages> frames{};
    drivers::can::SensorValues v;
    v.wrench_S[2] = fz;
    const int n = drivers::can::encodeSample(layout, v, counter, frames);
    for (int i = 0; i < n; ++i) server->trySend(frames[static_cast<std::size_t>(i)]);
    std::this_thread::sleep_for(1ms);
  }
  void drain() { source.drain(drivers::can::realtimeNowNs() / 1000, &history, &latest); }
};

TEST(CanSensorSourceLink, AReopenedTransportIsTakenByTheNextDrainAndSamplesResume) {
  SensorBench b;
  b.send(1, -11.0);
  b.drain();
  ASSERT_TRUE(b.latest.valid);
  EXPECT_NEAR(b.latest.wrench_S(2), -11.0, 0.01);
  EXPECT_FALSE(b.source.transportDown());

  b.server.reset();  // the sensor bridge / simulator goes away
  b.drain();
  EXPECT_FALSE(b.latest.valid);
  EXPECT_NE(b.latest.health_flags & kHealthTransportDown, 0u);
  EXPECT_TRUE(b.source.transportDown());

  b.server = std::make_unique<drivers::can::SeqpacketCanServer>(b.path);  // back
  b.source.offerTransport(drivers::can::openCanTransport("seqpacket:" + b.path));
  EXPECT_FALSE(b.source.transportDown());  // a replacement is waiting
  b.drain();                               // takes it (nothing sent yet)
  EXPECT_EQ(b.source.reconnects(), 1u);
  b.send(1, -22.0);
  b.send(2, -23.0);
  b.drain();
  EXPECT_TRUE(b.latest.valid);
  EXPECT_NEAR(b.latest.wrench_S(2), -23.0, 0.01);
  EXPECT_EQ(b.latest.health_flags & kHealthTransportDown, 0u);
  EXPECT_FALSE(b.source.transportDown());
  b.source.collectRetired();
}

}  // namespace
}  // namespace ftid::daemon

// The robot link's last error reaches systemd's STATUS= and the journal. It can quote bytes the
// controller sent (RTDE type names), so it is made one printable line: a reply such as
// "x\nWATCHDOG=1" must never become a second notification line.
TEST(PrintableLine, ControlAndNonAsciiBytesBecomeQuestionMarksAndLongTextIsCut) {
  EXPECT_EQ(ftid::daemon::printableLine("x\nWATCHDOG=1", 100), "x?WATCHDOG=1");
  EXPECT_EQ(ftid::daemon::printableLine(std::string("a\0b\r\t\x7f\xc3\xa9", 8), 100), "a?b?????");
  EXPECT_EQ(ftid::daemon::printableLine("plain text, kept", 100), "plain text, kept");
  EXPECT_EQ(ftid::daemon::printableLine("0123456789", 10), "0123456789");
  EXPECT_EQ(ftid::daemon::printableLine("0123456789abc", 10), "0123456...");
  for (int c = 0; c < 256; ++c) {
    const std::string one = ftid::daemon::printableLine(std::string(1, static_cast<char>(c)), 10);
    ASSERT_EQ(one.size(), 1u);
    EXPECT_TRUE(one[0] >= 0x20 && one[0] <= 0x7e) << "byte " << c;
  }
}
