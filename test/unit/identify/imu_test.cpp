// The payload-free IMU estimators (ftid/identify/imu.hpp) against the cell simulator, which
// computes the IMU's readings by its own route (docs/simulator.md) with biases, a mount rotation
// and a stream delay it is not told about.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <random>
#include <vector>

#include "ftid/common/error.hpp"
#include "ftid/identify/imu.hpp"
#include "imu_cell.hpp"

namespace ftid {
namespace {

using identify::estimateImu;
using identify::ImuEstimate;

double angleBetween(const Mat3& A, const Mat3& B) { return Eigen::AngleAxisd(A * B.transpose()).angle(); }

TEST(ImuEstimate, NoiseFreeRecoversTiltBiasesMountAndDelay) {
  const sim::CellSimConfig cfg = test::imuCellConfig(4.0);
  const samples::ContextSet cs = test::contextsOf(cfg);
  const ImuEstimate e = estimateImu(cs.samples);
  EXPECT_NEAR(e.acc.tilt_u_rad, cfg.tilt_u_rad, 2e-6);
  EXPECT_NEAR(e.acc.tilt_v_rad, cfg.tilt_v_rad, 2e-6);
  ASSERT_TRUE(e.acc.bias_estimated);
  // a_S is interpolated linearly at t - 12 ms: ~5e-5 m/s^2 of interpolation error
  EXPECT_LT((e.acc.bias_mps2 - cfg.imu.acc_bias_mps2).norm(), 1e-4) << e.acc.bias_mps2.transpose();
  EXPECT_LT((e.gyro.bias_radps - cfg.imu.gyro_bias_radps).norm(), 1e-6) << e.gyro.bias_radps.transpose();
  EXPECT_LT(angleBetween(e.gyro.R_SM, cfg.mounting.rotation()), 1e-6);
  EXPECT_LT((e.gyro.rpy_rad - cfg.mounting.rpy_rad).norm(), 1e-6) << e.gyro.rpy_rad.transpose();
  EXPECT_NEAR(e.gyro.delay_s, cfg.imu.delay_s, 2e-6);
}

TEST(ImuEstimate, LargeMountRotationAndNegativeDelayFromTheGyroAlone) {
  sim::CellSimConfig cfg = test::imuCellConfig(4.0);
  cfg.mounting.rpy_rad = Vec3(150.0, -50.0, 100.0) * test::kDegToRad;
  cfg.imu.delay_s = -0.037;
  const samples::ContextSet cs = test::contextsOf(cfg);
  const identify::GyroMountEstimate g = identify::estimateGyroMount(cs.samples);
  EXPECT_LT(angleBetween(g.R_SM, cfg.mounting.rotation()), 1e-6);
  EXPECT_NEAR(g.delay_s, -0.037, 2e-6);
  EXPECT_LT((g.bias_radps - cfg.imu.gyro_bias_radps).norm(), 1e-6);
}

TEST(ImuEstimate, WithoutDelayEstimateTheDelayIsZeroAndTheFitWorse) {
  const sim::CellSimConfig cfg = test::imuCellConfig(4.0);
  const samples::ContextSet cs = test::contextsOf(cfg);
  identify::ImuOptions o;
  o.estimate_delay = false;
  const identify::GyroMountEstimate g = identify::estimateGyroMount(cs.samples, o);
  EXPECT_FALSE(g.delay_estimated);
  EXPECT_EQ(g.delay_s, 0.0);
  // The 12 ms lag shows as residual: far above the noise-free fit's.
  EXPECT_GT(g.sigma_radps, 1e-4);
}

/// An IMU at 1/5 of the log's rate (sample-and-hold: each reading repeated over 5 rows while the
/// arm moves): the estimate is that of the rows each reading arrived with, bit for bit, and finds
/// the true delay. Kept, the held rows read as a lag of about half the IMU's period (3.9 ms on a
/// 500 Hz log, a "disagreement" with the configured delay).
TEST(ImuEstimate, HeldImuReadingsAreLeftOut) {
  sim::CellSimConfig cfg = test::imuCellConfig(4.0);
  cfg.rate_hz = 500.0;
  samples::ContextSet cs = test::contextsOf(cfg);
  sim::CellSimConfig noisy = cfg;  // a MEMS IMU's noise: no two readings are equal by chance
  noisy.noise.acc_std = 0.01;
  noisy.noise.gyro_std = 0.002;
  std::mt19937_64 rng(31);
  test::simulatorImuNoise(noisy)(cs.samples, rng);
  std::vector<effects::SampleContext> held = cs.samples, fresh;
  for (std::size_t i = 0; i < held.size(); ++i) {
    if (i % 5 == 0) {
      fresh.push_back(held[i]);
      continue;
    }
    held[i].imu_acc_S = held[i - 1].imu_acc_S;
    held[i].imu_w_S = held[i - 1].imu_w_S;
    held[i].imu_alpha_S = held[i - 1].imu_alpha_S;
  }
  const ImuEstimate h = estimateImu(held);
  const ImuEstimate f = estimateImu(fresh);
  EXPECT_EQ(h.held_rows, static_cast<int>(held.size() - fresh.size()));
  EXPECT_EQ(h.typical_hold_rows, 5);
  EXPECT_EQ(f.held_rows, 0);
  EXPECT_EQ(h.gyro.delay_s, f.gyro.delay_s);
  EXPECT_EQ(h.acc.tilt_u_rad, f.acc.tilt_u_rad);
  EXPECT_EQ(h.acc.bias_mps2, f.acc.bias_mps2);
  EXPECT_NEAR(h.gyro.delay_s, cfg.imu.delay_s, 4.0 * h.gyro.delay_std_s);
  EXPECT_NE(identify::formatImuEstimate(h).find("an IMU at 1/5 of the log's rate"), std::string::npos);
}

TEST(ImuEstimate, NoImuIsAClearError) {
  sim::CellSimConfig cfg = test::imuCellConfig(2.0);
  samples::ContextSet cs = test::contextsOf(cfg);
  for (auto& c : cs.samples) c.has_imu = false;
  try {
    (void)estimateImu(cs.samples);
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_NE(std::string(e.what()).find("no IMU columns"), std::string::npos) << e.what();
  }
}

TEST(ImuEstimate, InterpolatorRefusesGapsAndOutside) {
  sim::CellSimConfig cfg = test::imuCellConfig(1.0);
  samples::ContextSet cs = test::contextsOf(cfg);
  std::vector<effects::SampleContext> c(cs.samples.begin(), cs.samples.begin() + 20);
  c.insert(c.end(), cs.samples.begin() + 60, cs.samples.begin() + 80);
  const identify::KinematicsInterpolator kin(c);
  identify::KinematicsAt k;
  EXPECT_TRUE(kin.at(c[5].t + 0.3 * kin.step(), &k));
  EXPECT_FALSE(kin.at(c[19].t + 0.5 * kin.step(), &k));  // inside the gap
  EXPECT_FALSE(kin.at(c.front().t - 1e-3, &k));
  EXPECT_FALSE(kin.at(c.back().t + 1e-3, &k));
  // At a sample time it returns that sample's kinematics exactly.
  ASSERT_TRUE(kin.at(c[7].t, &k));
  EXPECT_EQ(k.w_S, c[7].w_S);
  std::swap(c[3], c[4]);
  EXPECT_THROW(identify::KinematicsInterpolator bad(c), DataError);
}

// A fast log (1 kHz: half steps of 0.5 ms over +-0.2 s would be 801 passes) is searched in two
// levels (imu.cpp coarseGyroDelay): the delay is found as exactly as at 125 Hz.
TEST(ImuEstimate, AFastLogsDelayIsFoundInTwoLevels) {
  sim::CellSimConfig cfg = test::imuCellConfig(3.0);
  cfg.rate_hz = 1000.0;
  cfg.imu.delay_s = -0.037;
  const samples::ContextSet cs = test::contextsOf(cfg);
  const identify::GyroMountEstimate g = identify::estimateGyroMount(cs.samples);
  EXPECT_NEAR(g.delay_s, -0.037, 2e-6);
  EXPECT_LT(angleBetween(g.R_SM, cfg.mounting.rotation()), 1e-6);
}

// The interpolator's bracket on uneven times (a jittered clock, and from sample 300 on a clock
// 20 steps ahead, where the uniform guess is too far off and the binary search answers): alpha_S
// is the linear interpolation between the samples std::upper_bound brackets s with, and the rates
// at a sample time are that sample's.
TEST(ImuEstimate, InterpolatorBracketsUnevenTimesAsABinarySearchWould) {
  const sim::CellSimConfig cfg = test::imuCellConfig(4.0);
  samples::ContextSet cs = test::contextsOf(cfg);
  std::vector<effects::SampleContext> c = cs.samples;
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> jitter(-0.3, 0.3);
  const double dt = 1.0 / cfg.rate_hz;
  for (std::size_t i = 0; i < c.size(); ++i) {
    c[i].t = dt * (static_cast<double>(i) + jitter(rng) + (i >= 300 ? 20.0 : 0.0));
  }
  c[40].t = c[39].t + 0.01 * dt;  // a near-duplicate stamp
  const identify::KinematicsInterpolator kin(c);
  std::vector<double> t(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) t[i] = c[i].t;
  std::uniform_real_distribution<double> when(t.front(), t.back());
  int inside = 0;
  for (int k = 0; k < 2000; ++k) {
    const double s = when(rng);
    const std::size_t j1 = static_cast<std::size_t>(std::upper_bound(t.begin(), t.end(), s) - t.begin());
    identify::KinematicsAt at;
    const bool ok = kin.at(s, &at);
    if (j1 == 0 || j1 >= t.size() || t[j1] - t[j1 - 1] > 1.5 * kin.step()) continue;  // edges, gaps
    ASSERT_TRUE(ok) << "s = " << s;
    const double x = (s - t[j1 - 1]) / (t[j1] - t[j1 - 1]);
    const Vec3 expected = (1.0 - x) * c[j1 - 1].alpha_S + x * c[j1].alpha_S;
    EXPECT_LT((at.alpha_S - expected).norm(), 1e-9 * (1.0 + expected.norm())) << "s = " << s;
    ++inside;
  }
  EXPECT_GT(inside, 1500);
  identify::KinematicsAt at;
  ASSERT_TRUE(kin.at(c[77].t, &at));
  EXPECT_EQ(at.w_S, c[77].w_S);
}

}  // namespace
}  // namespace ftid
