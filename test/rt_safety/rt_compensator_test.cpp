// Compensator::compute is allocation-free (counted by the test allocator) for the paper model,
// including the rejected-input path, and for the richest model (every effect that changes the
// compensation path: crosstalk's inverse, the mounting rotation, the delay ring of either sign) at
// 125 Hz and 500 Hz, with the motion from the kinematics or from the IMU.
#include <gtest/gtest.h>

#include <limits>

#include "alloc_controls.hpp"
#include "alloc_counter.hpp"
#include "ftid/compensate/compensator.hpp"

namespace ftid::compensate {
namespace {

TEST(RtCompensator, ComputeDoesNotAllocate) {
  const auto model = effects::Model::fromName("paper");
  Eigen::VectorXd theta = Eigen::VectorXd::LinSpaced(model.numParams(), 0.1, 1.0);
  Compensator comp(model, theta, 0.01, -0.02);
  effects::SampleContext ctx;
  ctx.R_BS = Eigen::AngleAxisd(0.3, Vec3(1.0, 2.0, 3.0).normalized()).toRotationMatrix();
  ctx.wrench_S << 1, 2, 3, 0.1, 0.2, 0.3;
  ctx.a_S = Vec3(0.5, -0.2, 0.1);
  Wrench contact, modelled;
  ASSERT_EQ(comp.compute(ctx, &contact, &modelled), Status::kOk);  // warm-up
  std::size_t allocations = 0;
  double sum = 0.0;
  {
    ftid::test::ScopedAllocationCounter counter;
    for (int i = 0; i < 1000; ++i) {
      ctx.t = 0.008 * i;
      ctx.a_S.x() = 0.001 * i;
      if (comp.compute(ctx, &contact, &modelled) != Status::kOk) sum += 1e9;
      sum += contact.sum();
    }
    ctx.wrench_S(0) = std::numeric_limits<double>::quiet_NaN();
    if (comp.compute(ctx, &contact, &modelled) != Status::kInvalidInput) sum += 1e9;
    allocations = counter.count();
  }
  EXPECT_EQ(allocations, 0u);
  EXPECT_LT(std::abs(sum), 1e8);
  // The counter does see allocations (the test can fail).
  {
    ftid::test::ScopedAllocationCounter counter;
    Compensator copy(model, theta, 0.0, 0.0);
    EXPECT_GT(counter.count(), 0u);
  }
}

struct RateCase {
  double rate_hz;
  double delay_s;
  bool imu_motion = false;  ///< MotionSource::kImu with biases
};

class RtCompensatorRichest : public ::testing::TestWithParam<RateCase> {};

TEST_P(RtCompensatorRichest, ComputeDoesNotAllocateWithEveryEffect) {
  const RateCase rc = GetParam();
  // The IMU's motion refuses a model with an apparent tilt (cable): the richest model without it.
  const auto model = effects::Model::fromName(
      std::string("paper+rigid_body") + (rc.imu_motion ? "" : "+cable") +
      "+temperature_drift+time_drift+crosstalk+mounting+sensor_delay+harmonic(q6,1)+payload(q6)");
  Eigen::VectorXd theta = Eigen::VectorXd::LinSpaced(model.numParams(), -0.01, 0.01);
  theta(model.paramIndex().column("mass")) = 2.0;
  NonlinearParams nl;
  nl.tilt_u_rad = 0.01;
  nl.mount_rpy_rad = Vec3(0.01, -0.02, 0.05);
  nl.delay_s = rc.delay_s;
  CompensatorOptions options;
  if (rc.imu_motion) {
    options.motion = MotionSource::kImu;
    options.imu_bias.acc_mps2 = Vec3(0.03, -0.02, 0.04);
    options.imu_bias.gyro_radps = Vec3(0.002, -0.003, 0.001);
  }
  Compensator comp(model, theta, nl, options);
  effects::SampleContext ctx;
  ctx.has_imu = true;
  ctx.has_temp = true;
  ctx.temp_degC = 26.0;
  ctx.wrench_S << 1, 2, 3, 0.1, 0.2, 0.3;
  Wrench contact, modelled;
  const int n = static_cast<int>(2.0 * rc.rate_hz);  // 2 s: the delay line fills and wraps
  std::size_t allocations = 0;
  int ok = 0;
  int not_ready = 0;
  double sum = 0.0;
  {
    ftid::test::ScopedAllocationCounter counter;
    for (int i = 0; i < n; ++i) {
      ctx.t = i / rc.rate_hz;
      ctx.q(5) = 0.5 * std::sin(ctx.t);
      ctx.R_BS = Eigen::AngleAxisd(0.3 + 0.2 * ctx.t, Vec3(1.0, 2.0, 3.0).normalized()).toRotationMatrix();
      ctx.w_S = Vec3(0.1, 0.2 * std::cos(ctx.t), 0.3);
      ctx.a_S = Vec3(0.5 * std::sin(ctx.t), -0.2, 0.1);
      ctx.imu_acc_S = Vec3(0.4 * std::sin(ctx.t), -0.3, 9.7);
      ctx.imu_w_S = Vec3(0.1, 0.2 * std::cos(ctx.t), 0.31);
      ctx.imu_alpha_S = Vec3(0.0, -0.2 * std::sin(ctx.t), 0.0);
      const Status st = comp.compute(ctx, &contact, &modelled);
      if (st == Status::kOk) {
        ++ok;
        sum += contact.sum();
      } else if (st == Status::kNotReady) {
        ++not_ready;
      } else {
        sum += 1e9;
      }
    }
    allocations = counter.count();
  }
  EXPECT_EQ(allocations, 0u);
  EXPECT_LT(std::abs(sum), 1e8);
  // The delay line needs |delay| of history before the first output.
  EXPECT_NEAR(not_ready, std::abs(rc.delay_s) * rc.rate_hz, 2.0);
  EXPECT_EQ(ok + not_ready, n);
}

INSTANTIATE_TEST_SUITE_P(Rates, RtCompensatorRichest,
                         ::testing::Values(RateCase{125.0, 0.024}, RateCase{500.0, 0.024},
                                           RateCase{500.0, -0.3}, RateCase{125.0, 0.0},
                                           RateCase{125.0, 0.0, true}, RateCase{500.0, -0.3, true}));

}  // namespace
}  // namespace ftid::compensate

// Positive controls: in this binary the counter sees a deliberate allocation of every kind.
FTID_ALLOCATION_COUNTER_CONTROLS();
