// Time-consistent pairing of robot states with sensor samples (ftid/daemon/time_pairing.hpp,
// docs/daemon.md "Time base"): the history and its interpolation, the robot clock map, and
// DaemonCycle with a fake sensor whose reading is a known function of host time, sampled at
// 1 kHz with a phase offset to a 125/500 Hz robot clock. The identity tested: the wrench paired
// with a robot state is the function at the robot state's time (within the interpolation error
// bound), whereas the newest sample (the previous behaviour) is not.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <random>
#include <vector>

#include "fakes.hpp"
#include "ftid/daemon/daemon_cycle.hpp"
#include "ftid/daemon/time_pairing.hpp"

namespace ftid::daemon {
namespace {


constexpr std::int64_t kT0 = 1'700'000'000'000'000;  // host time origin of the scenarios [us]

SensorSampleRecord sampleAt(std::int64_t t_us, double fx) {
  SensorSampleRecord s;
  s.recv_utime = t_us;
  s.wrench_S.setConstant(fx);
  s.valid = true;
  return s;
}

// ---- SensorHistory ----------------------------------------------------------------------------

TEST(SensorHistory, InterpolationReproducesALinearFunctionAtAnyTime) {
  // x(t) = 3 + 0.002 t (t in us from kT0), irregular sample spacing.
  auto x = [](std::int64_t t) { return 3.0 + 0.002 * static_cast<double>(t - kT0); };
  SensorHistory h;
  std::vector<std::int64_t> times;
  std::int64_t t = kT0;
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> dt(200, 1800);
  for (int i = 0; i < 40; ++i) {
    times.push_back(t);
    SensorSampleRecord s = sampleAt(t, x(t));
    s.has_imu = true;
    s.imu_w_S.setConstant(-x(t));
    s.has_temp = true;
    s.temp_degC = 2.0 * x(t);
    s.counter = i;
    s.recv_mono_us = 7'000'000 + 3 * i;  // unrelated to t: only carried, never interpolated
    h.push(s);
    t += dt(rng);
  }
  ASSERT_EQ(h.size(), 40);
  std::uniform_int_distribution<std::int64_t> query(times.front(), times.back());
  for (int k = 0; k < 500; ++k) {
    const std::int64_t tq = query(rng);
    SensorSampleRecord out;
    std::int64_t reach = -1;
    ASSERT_EQ(h.sampleAt(tq, &out, &reach), SensorPairing::kInterpolated);
    EXPECT_NEAR(out.wrench_S(3), x(tq), 1e-12);
    EXPECT_NEAR(out.imu_w_S(1), -x(tq), 1e-12);
    EXPECT_NEAR(out.temp_degC, 2.0 * x(tq), 1e-12);
    // recv_utime: the later bracketing sample (the first sample at or after tq).
    const auto it = std::lower_bound(times.begin(), times.end(), tq);
    EXPECT_EQ(out.recv_utime, *it);
    EXPECT_EQ(out.counter, static_cast<int>(it - times.begin()));
    EXPECT_EQ(out.recv_mono_us, 7'000'000 + 3 * out.counter);  // its age is the later one's
    EXPECT_EQ(reach, *it == tq ? 0 : *it - *(it - 1));
  }
}

TEST(SensorHistory, OutsideTheSamplesTheNearestOneIsUsed) {
  SensorHistory h;
  SensorSampleRecord out;
  std::int64_t reach = 0;
  EXPECT_EQ(h.sampleAt(kT0, &out, &reach), SensorPairing::kNone);
  h.push(sampleAt(kT0, 1.0));
  h.push(sampleAt(kT0 + 1000, 2.0));
  EXPECT_EQ(h.sampleAt(kT0 + 1700, &out, &reach), SensorPairing::kNewest);
  EXPECT_EQ(out.wrench_S(0), 2.0);
  EXPECT_EQ(reach, 700);
  EXPECT_EQ(h.sampleAt(kT0 - 300, &out, &reach), SensorPairing::kOldest);
  EXPECT_EQ(out.wrench_S(0), 1.0);
  EXPECT_EQ(reach, 300);
  EXPECT_EQ(h.sampleAt(kT0 + 250, &out, &reach), SensorPairing::kInterpolated);
  EXPECT_DOUBLE_EQ(out.wrench_S(0), 1.25);
}

TEST(SensorHistory, PushKeepsTimeOrderAndACappedLength) {
  SensorHistory h;
  h.push(sampleAt(0, 9.0));  // no receive time: not a sample
  EXPECT_TRUE(h.empty());
  for (int i = 0; i < SensorHistory::kCapacity + 30; ++i) h.push(sampleAt(kT0 + 1000 * i, i));
  EXPECT_EQ(h.size(), SensorHistory::kCapacity);
  EXPECT_EQ(h.at(0).wrench_S(0), 30.0);
  EXPECT_EQ(h.newest().wrench_S(0), SensorHistory::kCapacity + 29.0);
  // Same receive time as the newest: replaces it.
  h.push(sampleAt(h.newest().recv_utime, -1.0));
  EXPECT_EQ(h.size(), SensorHistory::kCapacity);
  EXPECT_EQ(h.newest().wrench_S(0), -1.0);
  // Older than the newest: the host clock stepped back, the history restarts.
  h.push(sampleAt(kT0 - 5'000'000, 4.0));
  EXPECT_EQ(h.size(), 1);
  EXPECT_EQ(h.newest().wrench_S(0), 4.0);
}

TEST(SensorHistory, BracketFlagsAndValidityCombine) {
  SensorHistory h;
  SensorSampleRecord bad = sampleAt(kT0 + 1000, 400.0);
  bad.valid = false;
  bad.health_flags = kHealthOutOfRange;
  h.push(sampleAt(kT0, 1.0));
  h.push(bad);
  h.push(sampleAt(kT0 + 2000, 1.0));
  SensorSampleRecord out;
  std::int64_t reach = 0;
  for (std::int64_t t : {kT0 + 500, kT0 + 1000, kT0 + 1500}) {
    ASSERT_EQ(h.sampleAt(t, &out, &reach), SensorPairing::kInterpolated);
    EXPECT_FALSE(out.valid) << t - kT0;
    EXPECT_EQ(out.health_flags, static_cast<std::uint32_t>(kHealthOutOfRange));
  }
  ASSERT_EQ(h.sampleAt(kT0, &out, &reach), SensorPairing::kInterpolated);  // exactly a sample
  EXPECT_TRUE(out.valid);
  EXPECT_EQ(out.wrench_S(0), 1.0);
}

// ---- RobotClockMap ----------------------------------------------------------------------------

// A controller clock r and a host clock h = C + r (+ drift); packets received after a latency
// L_min + jitter, with jitter = 0 on every 10th packet.
TEST(RobotClockMap, FindsTheOffsetPlusTheMinimumLatencyDespiteJitter) {
  const std::int64_t C = kT0 - 12'345'678'901;  // host - controller [us]
  const std::int64_t L_min = 150;
  std::mt19937 rng(5);
  std::exponential_distribution<double> jitter(1.0 / 300.0);
  RobotClockMap map(1.0);
  for (int n = 0; n < 2000; ++n) {
    const std::int64_t r_us = 12'345'678'901 + 8000 * n;
    const auto j = n % 10 == 0 ? 0 : static_cast<std::int64_t>(std::min(jitter(rng), 5000.0));
    const std::int64_t host = map.update(static_cast<double>(r_us) * 1e-6, C + r_us + L_min + j);
    // The minimum latency cannot be observed: the state is placed L_min after its instant.
    ASSERT_EQ(host, C + r_us + L_min) << n;
  }
  EXPECT_EQ(map.restarts(), 0u);
  // A latency spike of 100 ms does not move the estimate.
  const double r = 12345.678901 + 8000 * 2000 * 1e-6;
  EXPECT_EQ(map.update(r, C + std::llround(r * 1e6) + 100'000), C + std::llround(r * 1e6) + L_min);
}

TEST(RobotClockMap, FollowsClockDriftWithinTwoWindows) {
  // Host clock 50 ppm fast against the controller: the offset grows 50 us per second.
  const double drift = 50e-6, window_s = 1.0;
  RobotClockMap map(window_s);
  double worst = 0.0;
  for (int n = 0; n < 125 * 30; ++n) {
    const double r = 100.0 + 0.008 * n;
    const double true_host = static_cast<double>(kT0) + (r - 100.0) * 1e6 * (1.0 + drift);
    const std::int64_t got = map.update(r, std::llround(true_host));
    worst = std::max(worst, true_host - static_cast<double>(got));
  }
  // The minimum lags the growing offset by at most two windows of drift (+1 us rounding).
  EXPECT_LE(worst, 2.0 * window_s * 1e6 * drift + 1.0);
  EXPECT_GT(worst, 0.5 * window_s * 1e6 * drift);  // it does lag: the bound is not vacuous
}

TEST(RobotClockMap, RestartsWhenAClockJumps) {
  RobotClockMap map;
  EXPECT_EQ(map.update(std::numeric_limits<double>::quiet_NaN(), kT0), 0);
  EXPECT_FALSE(map.valid());
  EXPECT_EQ(map.update(500.0, kT0), kT0);
  EXPECT_EQ(map.update(500.008, kT0 + 8000), kT0 + 8000);
  // Controller restarted: its time starts again near 0.
  EXPECT_EQ(map.update(0.008, kT0 + 20'000), kT0 + 20'000);
  EXPECT_EQ(map.restarts(), 1u);
  // Host clock set forward by 2 s.
  EXPECT_EQ(map.update(0.016, kT0 + 2'028'000), kT0 + 2'028'000);
  EXPECT_EQ(map.restarts(), 2u);
  // Host clock set back by 1 s: a smaller offset is simply the new minimum.
  EXPECT_EQ(map.update(0.024, kT0 + 1'036'000), kT0 + 1'036'000);
  EXPECT_EQ(map.restarts(), 2u);
}

// ---- DaemonCycle against a sensor whose reading is a known function of host time ------------

/// A sensor sampled at host times t_k = first + k * period_us (rounded to us) whose reading is
/// wrench(t_k); sample k arrives (is received) at t_k. drain() hands over every sample that has
/// arrived by `now`; waitForSample() advances the fake clock as a real wait would.
class ClockedSensor : public SensorSource {
 public:
  using Fn = Wrench (*)(double t_s);  // t_s: seconds since kT0
  ClockedSensor(Fn fn, std::int64_t first_us, double period_us)
      : fn_(fn), first_us_(first_us), period_us_(period_us) {}
  int invalid_k = -1;   ///< this sample is out of range (invalid)
  int nan_k = -1;       ///< this sample has a NaN
  int last_k = 1 << 30; ///< no samples after this one (the sensor went silent)
  int waits = 0;
  std::int64_t time(int k) const {
    return first_us_ + std::llround(static_cast<double>(k) * period_us_);
  }
  Wrench value(std::int64_t t_us) const { return fn_(static_cast<double>(t_us - kT0) * 1e-6); }
  void drain(std::int64_t now_utime, SensorHistory* history,
             SensorSampleRecord* latest) noexcept override {
    deliverUntil(now_utime, history);
    *latest = newest_;
  }
  bool waitForSample(std::int64_t t_utime, std::chrono::nanoseconds timeout,
                     SensorHistory* history) noexcept override {
    ++waits;
    const std::int64_t deadline = test::g_fake_now_us + timeout.count() / 1000;
    int k = next_k_;
    while (k <= last_k && time(k) < t_utime) ++k;
    const bool comes = k <= last_k && time(k) <= deadline;
    test::g_fake_now_us = comes ? std::max(test::g_fake_now_us, time(k)) : deadline;
    deliverUntil(test::g_fake_now_us, history);
    return comes;
  }

 private:
  void deliverUntil(std::int64_t now_utime, SensorHistory* history) {
    while (next_k_ <= last_k && time(next_k_) <= now_utime) {
      SensorSampleRecord s;
      s.recv_utime = time(next_k_);
      s.recv_mono_us = s.recv_utime;  // the cycle reads one fake clock as both
      s.counter = next_k_;
      s.wrench_S = value(s.recv_utime);
      s.valid = true;
      if (next_k_ == invalid_k) {
        s.valid = false;
        s.health_flags = kHealthOutOfRange;
      }
      if (next_k_ == nan_k) s.wrench_S(2) = std::numeric_limits<double>::quiet_NaN();
      history->push(s);
      newest_ = s;
      ++next_k_;
    }
  }
  Fn fn_;
  std::int64_t first_us_;
  double period_us_;
  int next_k_ = 0;
  SensorSampleRecord newest_;  // recv_utime 0: nothing yet
};

/// Hands out the robot state the test put into `next`.
class ScriptedArm : public ArmStateSource {
 public:
  RobotStateRecord next;
  Status waitForState(std::chrono::nanoseconds, RobotStateRecord* out) noexcept override {
    *out = next;
    return Status::kOk;
  }
};

Wrench linearWrench(double t) {
  Wrench w;
  w << 5.0 + 40.0 * t, -3.0 - 25.0 * t, 12.0 + 60.0 * t, 0.1 + 2.0 * t, -0.2 + 1.5 * t, 0.05 - 0.8 * t;
  return w;
}

constexpr double kSmoothAmplitude = 20.0;          // [N]
constexpr double kSmoothOmega = 2.0 * M_PI * 2.0;  // 2 Hz [rad/s]
Wrench smoothWrench(double t) {
  Wrench w;
  for (int i = 0; i < 6; ++i) w(i) = kSmoothAmplitude * std::sin(kSmoothOmega * t + 0.7 * i);
  return w;
}

struct CycleResult {
  std::int64_t robot_host_us = 0;  ///< the robot state's instant on the host clock (truth)
  std::int64_t now_us = 0;         ///< the cycle's start (after any wait for the sensor)
  CycleRecord rec;
  SensorSampleRecord newest;  ///< the newest sample: what the previous behaviour paired
  SensorPairing pairing = SensorPairing::kNone;
};

struct RunResult {
  std::vector<CycleResult> cycles;
  std::uint64_t waits = 0, wait_timeouts = 0;
};

/// Runs `cycles` robot states through waitForTick() + onTick() as the executor does: period
/// robot_period_us, first instant robot_first_us on the host clock, received after a seeded
/// jitter (zero on every 10th packet: minimum latency 0) and never before the previous packet;
/// packet `spike_cycle` is `spike_us` late.
RunResult runCycles(ClockedSensor* sensor, int cycles, std::int64_t robot_first_us,
              std::int64_t robot_period_us, std::int64_t max_wait_us = 1500,
              int spike_cycle = -1, std::int64_t spike_us = 0) {
  ScriptedArm arm;
  test::FixedMotion motion;
  rt::OwnedSwapSlot<Compensation> slot(std::make_unique<test::OffsetCompensation>(Wrench::Zero()));
  CycleOptions opt;
  opt.stale_timeout_us = 20'000;
  opt.max_sensor_wait_us = max_wait_us;
  opt.now_us = &test::fakeNowUs;
  DaemonCycle cycle(&arm, sensor, &motion, &slot, nullptr, opt);
  std::mt19937 rng(42);
  std::exponential_distribution<double> jitter(1.0 / 250.0);
  RunResult run;
  std::int64_t prev_recv = 0;
  for (int n = 0; n < cycles; ++n) {
    CycleResult r;
    r.robot_host_us = robot_first_us + robot_period_us * n;
    auto j = n % 10 == 0 ? 0 : static_cast<std::int64_t>(std::min(jitter(rng), 3000.0));
    if (n == spike_cycle) j = spike_us;
    arm.next.valid = true;
    arm.next.robot_time = 7200.0 + static_cast<double>(robot_period_us * n) * 1e-6;  // controller
    arm.next.recv_utime = std::max(r.robot_host_us + j, prev_recv);
    prev_recv = arm.next.recv_utime;
    test::g_fake_now_us = arm.next.recv_utime + 15;
    EXPECT_EQ(cycle.waitForTick(std::chrono::milliseconds(12)), Status::kOk);
    r.now_us = test::g_fake_now_us;
    cycle.onTick();
    r.rec = cycle.lastRecord();
    r.newest = cycle.lastNewestSample();
    r.pairing = cycle.lastPairing();
    run.cycles.push_back(r);
  }
  run.waits = cycle.counters().sensor_waits.load();
  run.wait_timeouts = cycle.counters().sensor_wait_timeouts.load();
  return run;
}

double maxAbs(const Wrench& w) { return w.cwiseAbs().maxCoeff(); }

struct Timing {
  const char* name;
  double sensor_period_us;
  std::int64_t sensor_phase_us;
  std::int64_t robot_period_us;
};
const Timing kTimings[] = {
    {"1 kHz sensor, 125 Hz robot", 1000.0, 337, 8000},
    {"1 kHz sensor, 500 Hz robot", 1000.0, 611, 2000},
    {"999.3 us sensor (phase drifts), 125 Hz robot", 999.3, 50, 8000},
};

TEST(DaemonCyclePairing, LinearWrenchIsPairedAtTheRobotStatesTime) {
  for (const Timing& tm : kTimings) {
    SCOPED_TRACE(tm.name);
    ClockedSensor sensor(&linearWrench, kT0 - 50'000 + tm.sensor_phase_us, tm.sensor_period_us);
    const RunResult run = runCycles(&sensor, 600, kT0, tm.robot_period_us);
    double worst_new = 0.0;
    int old_wrong = 0;
    for (const CycleResult& r : run.cycles) {
      ASSERT_TRUE(r.rec.wrench_valid);
      ASSERT_EQ(r.pairing, SensorPairing::kInterpolated);
      const Wrench truth = sensor.value(r.robot_host_us);
      worst_new = std::max(worst_new, maxAbs(r.rec.sensor.wrench_S - truth));
      EXPECT_LE(maxAbs(r.rec.contact_S - truth), 1e-9);  // compensated with the paired sample
      if (maxAbs(r.newest.wrench_S - truth) > 1e-3) ++old_wrong;
    }
    // Exact up to rounding: the function is linear in time.
    EXPECT_LE(worst_new, 1e-9);
    // The newest sample (the previous behaviour) misses the function in (nearly) every cycle:
    // by the slope (up to 60 N/s) times up to a sensor period.
    EXPECT_GE(old_wrong, static_cast<int>(0.9 * static_cast<double>(run.cycles.size())));
    EXPECT_EQ(run.wait_timeouts, 0u);
    EXPECT_GT(run.waits, 0u);  // the following sample had to be waited for in some cycles
  }
}

TEST(DaemonCyclePairing, SmoothWrenchIsWithinTheInterpolationErrorBound) {
  // Linear interpolation of f over spacing h errs by at most h^2/8 max|f''|.
  for (const Timing& tm : kTimings) {
    SCOPED_TRACE(tm.name);
    ClockedSensor sensor(&smoothWrench, kT0 - 50'000 + tm.sensor_phase_us, tm.sensor_period_us);
    const RunResult run = runCycles(&sensor, 600, kT0, tm.robot_period_us);
    const double h = (tm.sensor_period_us + 1.0) * 1e-6;
    const double bound = h * h / 8.0 * kSmoothAmplitude * kSmoothOmega * kSmoothOmega + 1e-9;
    double worst_new = 0.0, sq_old = 0.0;
    for (const CycleResult& r : run.cycles) {
      ASSERT_TRUE(r.rec.wrench_valid);
      const Wrench truth = sensor.value(r.robot_host_us);
      worst_new = std::max(worst_new, maxAbs(r.rec.sensor.wrench_S - truth));
      sq_old += (r.newest.wrench_S - truth).squaredNorm() / 6.0;
    }
    EXPECT_LE(worst_new, bound);
    // The newest sample is off by |f'| times up to a sensor period: far outside the bound.
    EXPECT_GT(std::sqrt(sq_old / static_cast<double>(run.cycles.size())), 20.0 * bound);
  }
}

TEST(DaemonCyclePairing, WithoutWaitingOnlyLateRobotStatesAreBracketed) {
  // max_sensor_wait_us = 0: a robot state whose packet came before the following sample is
  // paired with the newest sample (one-sided), exactly the previous behaviour; one that came
  // late enough is interpolated.
  ClockedSensor sensor(&linearWrench, kT0 - 50'000 + 337, 1000.0);
  const RunResult run = runCycles(&sensor, 300, kT0, 8000, 0);
  EXPECT_EQ(run.waits, 0u);
  int one_sided = 0, bracketed = 0;
  for (const CycleResult& r : run.cycles) {
    ASSERT_TRUE(r.rec.wrench_valid);
    const Wrench truth = sensor.value(r.robot_host_us);
    if (r.now_us < r.robot_host_us + 337) {  // the following sample (at +337 us) not there yet
      ASSERT_EQ(r.pairing, SensorPairing::kNewest);
      EXPECT_EQ(r.rec.sensor.wrench_S, r.newest.wrench_S);
      EXPECT_GT(maxAbs(r.rec.sensor.wrench_S - truth), 1e-3);
      ++one_sided;
    } else {
      ASSERT_EQ(r.pairing, SensorPairing::kInterpolated);
      EXPECT_LE(maxAbs(r.rec.sensor.wrench_S - truth), 1e-9);
      ++bracketed;
    }
  }
  EXPECT_GT(one_sided, 30);  // every 10th packet has no jitter
  EXPECT_GT(bracketed, 30);
}

TEST(DaemonCyclePairing, AWaitThatTimesOutUsesTheNewestSample) {
  // A 200 Hz sensor: the sample after the robot state is up to 5 ms away, beyond the 1.5 ms
  // bound: the wait times out and the newest sample is used.
  ClockedSensor sensor(&linearWrench, kT0 - 50'000 + 1337, 5000.0);
  const RunResult run = runCycles(&sensor, 100, kT0, 8000);
  EXPECT_GT(run.wait_timeouts, 10u);
  int one_sided = 0;
  for (const CycleResult& r : run.cycles) {
    ASSERT_TRUE(r.rec.wrench_valid);
    if (r.pairing == SensorPairing::kNewest) {
      ++one_sided;
      EXPECT_LE(r.now_us - r.robot_host_us, 1500 + 3015);  // waited at most 1.5 ms after arrival
    } else {
      ASSERT_EQ(r.pairing, SensorPairing::kInterpolated);
      EXPECT_LE(maxAbs(r.rec.sensor.wrench_S - sensor.value(r.robot_host_us)), 1e-9);
    }
  }
  EXPECT_EQ(static_cast<std::uint64_t>(one_sided), run.wait_timeouts);
}

TEST(DaemonCyclePairing, StalenessIsFlaggedExactlyWhenTheNewestSampleIsTooOld) {
  ClockedSensor sensor(&linearWrench, kT0 - 50'000 + 337, 1000.0);
  sensor.last_k = 50 + 300;  // silent from kT0 + 300.337 ms on
  const RunResult run = runCycles(&sensor, 100, kT0, 8000);
  const std::int64_t last_t = sensor.time(sensor.last_k);
  int stale = 0, valid = 0;
  for (const CycleResult& r : run.cycles) {
    const bool too_old = r.now_us - last_t > 20'000;  // the rule for the newest sample
    EXPECT_EQ((r.rec.fault_bits & kFaultSensorStale) != 0, too_old) << r.now_us - last_t;
    EXPECT_EQ((r.rec.sensor.health_flags & kHealthStale) != 0, too_old);
    EXPECT_EQ(r.rec.wrench_valid, !too_old);
    if (too_old) {
      EXPECT_EQ(r.rec.contact_S, Wrench::Zero());
      ++stale;
    } else {
      ++valid;
    }
    // Past the last sample the newest one is used (one-sided), as before.
    if (r.robot_host_us > last_t) {
      EXPECT_EQ(r.pairing, SensorPairing::kNewest);
    }
  }
  EXPECT_GT(stale, 50);
  EXPECT_GT(valid, 30);
  // While the sensor is silent the cycle waits only until the newest sample is stale: cycles at
  // +0.3..20 ms after the last sample (at most 3 at 125 Hz), never afterwards.
  EXPECT_LE(run.wait_timeouts, 3u);
}

TEST(DaemonCyclePairing, AnInvalidOrNonFiniteBracketingSampleIsNeverCompensated) {
  ClockedSensor sensor(&linearWrench, kT0 - 50'000 + 337, 1000.0);
  sensor.invalid_k = 50 + 80;  // at kT0 + 80.337 ms: brackets the robot state at kT0 + 80 ms
  sensor.nan_k = 50 + 160;     // at kT0 + 160.337 ms: brackets kT0 + 160 ms
  const RunResult run = runCycles(&sensor, 40, kT0, 8000);
  for (std::size_t n = 0; n < run.cycles.size(); ++n) {
    const CycleResult& r = run.cycles[n];
    if (n == 10) {
      EXPECT_FALSE(r.rec.wrench_valid);
      EXPECT_NE(r.rec.fault_bits & kFaultSensorInvalid, 0u);
      EXPECT_EQ(r.rec.fault_bits & kFaultSensorStale, 0u);
      EXPECT_NE(r.rec.sensor.health_flags & kHealthOutOfRange, 0u);
    } else if (n == 20) {
      EXPECT_FALSE(r.rec.wrench_valid);
      EXPECT_NE(r.rec.sensor.health_flags & kHealthNonFinite, 0u);
      EXPECT_TRUE(r.rec.contact_S.allFinite());
    } else {
      EXPECT_TRUE(r.rec.wrench_valid) << n;
    }
  }
}

TEST(DaemonCyclePairing, ARobotStateOlderThanTheHistoryIsStaleNotMispaired) {
  // Packet 30 arrives 200 ms late and the following ones queue behind it: the first of them lie
  // before the 128 samples (128 ms) the history holds. Within the stale timeout of the oldest
  // sample they get that one (one-sided), beyond it they are stale; once the queue's instants
  // are inside the history they are paired exactly again (old, but time-consistent).
  ClockedSensor sensor(&linearWrench, kT0 - 50'000 + 337, 1000.0);
  const RunResult run = runCycles(&sensor, 60, kT0, 8000, 1500, 30, 200'000);
  // Issue 26: whatever the pairing, a cycle is valid only if the sample it uses is at most the
  // stale timeout old on the host clock; the backlog's exact (time-consistent) pairings are no
  // longer published as valid once their samples are older than that.
  int stale = 0, one_sided = 0, backlog_exact = 0;
  for (const CycleResult& r : run.cycles) {
    const std::int64_t oldest_t = sensor.time(r.newest.counter - (SensorHistory::kCapacity - 1));
    const std::int64_t before_oldest = oldest_t - r.robot_host_us;
    const bool fresh = r.now_us - r.rec.sensor.recv_utime <= 20'000;
    EXPECT_EQ(r.rec.sensor_age_us, r.now_us - r.rec.sensor.recv_utime);
    if (before_oldest > 0) {
      EXPECT_EQ(r.pairing, SensorPairing::kOldest);
      EXPECT_EQ(r.rec.sensor.recv_utime, oldest_t);
      const bool too_far = before_oldest > 20'000;
      EXPECT_EQ(r.rec.wrench_valid, !too_far && fresh);
      EXPECT_EQ((r.rec.fault_bits & kFaultSensorStale) != 0, too_far || !fresh);
      EXPECT_EQ(r.rec.sensor.valid, !too_far);  // the sample itself: stale only by the pairing
      ++(too_far ? stale : one_sided);
    } else {
      EXPECT_EQ(r.rec.wrench_valid, fresh) << r.rec.cycle;
      EXPECT_EQ(r.pairing, SensorPairing::kInterpolated);
      EXPECT_LE(maxAbs(r.rec.sensor.wrench_S - sensor.value(r.robot_host_us)), 1e-9);
      if (r.now_us - r.robot_host_us > 20'000) {
        ++backlog_exact;
        EXPECT_FALSE(r.rec.wrench_valid) << "a backlog cycle with a " << r.rec.sensor_age_us << " us old sample";
        EXPECT_TRUE(r.rec.sensor.valid);  // time-consistent data, still recorded for identification
        EXPECT_NE(r.rec.fault_bits & kFaultSensorStale, 0u);
      }
    }
  }
  EXPECT_GE(stale, 5);
  EXPECT_GE(one_sided, 1);
  EXPECT_GE(backlog_exact, 5);
}

// Issue 26, item 2: the RTDE timestamp frozen for 1 s at a time while the arm moves. Before,
// the robot state's frozen time paired ever older samples, each time-consistent with it, and
// cycles were published valid with samples up to 128 ms old. Now no valid cycle uses a sample
// older than the stale timeout, the frozen clock is detected and counted, and cycles are
// invalid while it is frozen and for the recovery time after it.
TEST(DaemonCyclePairing, AFrozenControllerClockNeverPublishesStaleSamplesAsValid) {
  ClockedSensor sensor(&smoothWrench, kT0 - 50'000 + 337, 1000.0);
  ScriptedArm arm;
  test::FixedMotion motion;
  rt::OwnedSwapSlot<Compensation> slot(std::make_unique<test::OffsetCompensation>(Wrench::Zero()));
  CycleOptions opt;
  opt.stale_timeout_us = 20'000;
  opt.now_us = &test::fakeNowUs;  // and the monotonic clock of the clock check (one fake)
  DaemonCycle cycle(&arm, &sensor, &motion, &slot, nullptr, opt);
  std::mt19937 rng(7);
  std::exponential_distribution<double> jitter(1.0 / 250.0);
  const int n_cycles = 1000;  // 8 s at 125 Hz: frozen during [1, 2) s and [4, 5) s
  auto frozen = [](int n) { return (n >= 125 && n < 250) || (n >= 500 && n < 625); };
  double robot_time = 7200.0;
  int valid = 0, valid_after_recovery = 0, cycles_after_recovery = 0;
  std::int64_t oldest_valid_age = 0;
  for (int n = 0; n < n_cycles; ++n) {
    const std::int64_t host_us = kT0 + 8000LL * n;
    if (!frozen(n)) robot_time = 7200.0 + 0.008 * n;  // resumes at its true value: a jump
    arm.next.valid = true;
    arm.next.robot_time = robot_time;
    arm.next.recv_utime = host_us + (n % 10 == 0 ? 0 : static_cast<std::int64_t>(std::min(jitter(rng), 3000.0)));
    test::g_fake_now_us = arm.next.recv_utime + 15;
    ASSERT_EQ(cycle.waitForTick(std::chrono::milliseconds(12)), Status::kOk);
    cycle.onTick();
    const CycleRecord& r = cycle.lastRecord();
    if (r.wrench_valid) {
      ++valid;
      oldest_valid_age = std::max(oldest_valid_age, r.sensor_age_us);
      EXPECT_FALSE(frozen(n)) << "cycle " << n << " valid with a frozen controller clock";
    }
    if (frozen(n)) {
      EXPECT_NE(r.fault_bits & kFaultRobotClock, 0u) << n;
      EXPECT_FALSE(r.robot.valid) << n;  // left out of identification logs as well
    }
    // 0.5 s (63 cycles) after each freeze the clock is sane again and cycles are valid.
    const bool recovered = (n >= 250 + 63 && n < 500) || n >= 625 + 63;
    if (recovered) {
      ++cycles_after_recovery;
      if (r.wrench_valid) ++valid_after_recovery;
    }
  }
  EXPECT_LE(oldest_valid_age, 20'000);
  EXPECT_GE(cycle.counters().robot_clock_faults.load(), 2u * 124u);  // every frozen state after the first
  EXPECT_GT(cycle.counters().robot_clock_invalid.load(), 2u * 124u);
  EXPECT_EQ(valid_after_recovery, cycles_after_recovery);
  EXPECT_GT(valid, 600);
}

TEST(ControllerClockCheck, DetectsStopsJumpsAndWrongRatesAndRecovers) {
  ControllerClockCheck::Options o;
  ControllerClockCheck c(o);
  std::int64_t host = 1'000'000;
  double robot = 50.0;
  for (int k = 0; k < 1000; ++k, host += 8000, robot += 0.008) EXPECT_TRUE(c.update(robot, host)) << k;
  EXPECT_EQ(c.faults(), 0u);
  EXPECT_FALSE(c.update(robot - 0.008, host));  // the same time again: stopped
  EXPECT_EQ(c.lastFault(), ClockFault::kStopped);
  host += 8000;
  EXPECT_FALSE(c.update(robot + 1.0, host));  // 1 s ahead in one 8 ms step: a jump
  EXPECT_EQ(c.lastFault(), ClockFault::kJump);
  robot += 1.0;
  int k = 0;
  for (; !c.update(robot, host); ++k, host += 8000, robot += 0.008) {
  }
  EXPECT_NEAR(k * 8000, o.recovery_us, 8000);  // sane after the recovery time
  EXPECT_FALSE(c.update(1.0, host + 8000));    // backwards
  EXPECT_EQ(c.lastFault(), ClockFault::kBackwards);
  // 10 % fast for longer than the rate window: a rate fault (no single step is a jump).
  ControllerClockCheck fast(o);
  host = 0;
  robot = 10.0;
  bool seen = false;
  for (int i = 0; i < 1000 && !seen; ++i, host += 8000, robot += 0.0088) seen = !fast.update(robot, host);
  EXPECT_TRUE(seen);
  EXPECT_EQ(fast.lastFault(), ClockFault::kRate);
  // Host-side stalls (a state processed 200 ms late, then the backlog quickly) are no fault.
  ControllerClockCheck stall(o);
  host = 0;
  robot = 10.0;
  for (int i = 0; i < 2000; ++i, robot += 0.008) {
    host += (i % 500 == 100) ? 200'000 : (i % 500 > 100 && i % 500 < 125 ? 0 : 8000);
    EXPECT_TRUE(stall.update(robot, host)) << i;
  }
}

}  // namespace
}  // namespace ftid::daemon
