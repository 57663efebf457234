// Offline identification and online compensation must see exactly the same inputs: one recorded
// run goes through the daemon's cycle (online: the context the compensation receives) and, as
// recorded (cycle records -> LCM messages -> the cycle log), through samples::buildContexts (offline: what
// identification, `ftid compensate` and the lab use). Every context must be identical, bit for bit.
#include <gtest/gtest.h>

#include <array>
#include <cstring>
#include <random>
#include <vector>

#include "fakes.hpp"
#include "ftid/daemon/adapters.hpp"
#include "ftid/daemon/daemon_cycle.hpp"
#include "ftid/model/kinematics.hpp"
#include "ftid/samples/context.hpp"
#include "ftid/transport/codec.hpp"
#include "ftid/transport/lcm_to_csv.hpp"
#include "test_paths.hpp"

namespace ftid::daemon {
namespace {

constexpr double kTiltU = 0.013;
constexpr double kTiltV = -0.027;

/// Keeps a copy of every context the cycle hands to the compensation (modelled = 0).
class CapturingCompensation : public Compensation {
 public:
  static constexpr std::size_t kCapacity = 64;
  std::array<effects::SampleContext, kCapacity> seen{};
  std::size_t count = 0;
  double tiltU() const noexcept override { return kTiltU; }
  double tiltV() const noexcept override { return kTiltV; }
  bool compute(const effects::SampleContext& ctx, Wrench* contact, Wrench* modelled) noexcept override {
    if (count < kCapacity) seen[count++] = ctx;
    modelled->setZero();
    *contact = ctx.wrench_S;
    return true;
  }
};

template <class M>
bool sameBits(const M& a, const M& b) {
  return std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<std::size_t>(a.size())) == 0;
}
bool sameBits(double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; }

void expectIdentical(const effects::SampleContext& on, const effects::SampleContext& off, std::size_t i) {
  SCOPED_TRACE("cycle " + std::to_string(i));
  EXPECT_TRUE(sameBits(on.t, off.t)) << on.t << " vs " << off.t;
  EXPECT_TRUE(sameBits(on.t_model, off.t_model)) << on.t_model << " vs " << off.t_model;
  EXPECT_TRUE(sameBits(on.q, off.q));
  EXPECT_TRUE(sameBits(on.qd, off.qd));
  EXPECT_TRUE(sameBits(on.R_BS, off.R_BS));
  EXPECT_TRUE(sameBits(on.p_BS_B, off.p_BS_B));
  EXPECT_TRUE(sameBits(on.w_S, off.w_S));
  EXPECT_TRUE(sameBits(on.alpha_S, off.alpha_S));
  EXPECT_TRUE(sameBits(on.a_S, off.a_S));
  EXPECT_TRUE(sameBits(on.g_S, off.g_S)) << on.g_S.transpose() << " vs " << off.g_S.transpose();
  EXPECT_TRUE(sameBits(on.wrench_S, off.wrench_S));
  EXPECT_TRUE(sameBits(on.imu_acc_S, off.imu_acc_S));
  EXPECT_TRUE(sameBits(on.imu_w_S, off.imu_w_S));
  EXPECT_TRUE(sameBits(on.imu_alpha_S, off.imu_alpha_S));
  EXPECT_TRUE(sameBits(on.temp_degC, off.temp_degC));
  EXPECT_TRUE(sameBits(on.wrench_model_S, off.wrench_model_S));
  EXPECT_EQ(on.has_imu, off.has_imu);
  EXPECT_EQ(on.has_temp, off.has_temp);
  EXPECT_EQ(on.has_joints, off.has_joints);
  // extra/extra_names differ by design: the recorded log carries its bookkeeping columns
  // (cycle, sensor_age_ms, fault_bits, host_time); the loop has none.
}

TEST(SamplePaths, OnlineAndOfflineContextsAreIdenticalBitForBit) {
  const model::RobotKinematics kin = model::RobotKinematics::fromUrdfFile(ftid::test::sourcePath("/config/ur10.urdf"));
  samples::ContextOptions options;
  options.R_FS = Eigen::AngleAxisd(0.7, Vec3(0.3, -0.5, 0.8).normalized()).toRotationMatrix();
  options.p_FS_F = Vec3(0.004, -0.002, 0.031);
  options.tilt_u_rad = kTiltU;
  options.tilt_v_rad = kTiltV;
  model::RobotKinematics mounted = kin;
  mounted.setSensorMount(options.R_FS, options.p_FS_F);
  KinematicsMotionModel motion(mounted);

  auto* comp = new CapturingCompensation;
  rt::OwnedSwapSlot<Compensation> slot{std::unique_ptr<Compensation>(comp)};
  test::FakeArm arm;
  test::FakeSensor sensor;
  sensor.sample.has_imu = true;
  sensor.sample.has_temp = true;
  test::RecordingSink sink;
  CycleOptions opt;
  opt.now_us = &test::fakeNowUs;
  DaemonCycle cycle(&arm, &sensor, &motion, &slot, &sink, opt);

  std::mt19937 rng(613);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  constexpr int kCycles = 40;
  for (int k = 0; k < kCycles; ++k) {
    for (int j = 0; j < 6; ++j) {
      arm.state.q(j) = 2.5 * u(rng);
      arm.state.qd(j) = 1.5 * u(rng);
      arm.state.qdd(j) = 8.0 * u(rng);
    }
    for (int a = 0; a < 6; ++a) sensor.sample.wrench_S(a) = 30.0 * u(rng);
    for (int a = 0; a < 3; ++a) {
      sensor.sample.imu_acc_S(a) = 10.0 * u(rng);
      sensor.sample.imu_w_S(a) = u(rng);
      sensor.sample.imu_alpha_S(a) = 5.0 * u(rng);
    }
    sensor.sample.temp_degC = 25.0 + u(rng);
    ++sensor.sample.counter;
    test::g_fake_now_us += 8000;
    ASSERT_EQ(cycle.waitForTick(std::chrono::milliseconds(12)), Status::kOk);
    cycle.onTick();
  }
  ASSERT_EQ(sink.count, kCycles);
  ASSERT_EQ(comp->count, static_cast<std::size_t>(kCycles));

  // Offline: the records as ftidd publishes and `ftid --identify` / lcm-to-csv record them.
  transport::CycleLogBuilder builder("recorded run");
  for (int k = 0; k < sink.count; ++k) {
    ftid_lcm::cycle_sample_t msg{};
    transport::toLcm(sink.records[static_cast<std::size_t>(k)], &msg);
    CycleRecord rec;
    transport::fromLcm(msg, &rec);
    ASSERT_TRUE(builder.add(rec)) << "cycle " << k;
  }
  const logio::LogData log = builder.finish();
  ASSERT_TRUE(log.has_imu);
  ASSERT_TRUE(log.has_temp);
  const samples::ContextSet offline = samples::buildContexts(log, kin, options);
  ASSERT_EQ(offline.size(), comp->count);
  for (std::size_t i = 0; i < offline.size(); ++i) expectIdentical(comp->seen[i], offline.samples[i], i);
}

}  // namespace
}  // namespace ftid::daemon
