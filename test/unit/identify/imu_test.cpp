// The payload-free IMU estimators (ftid/identify/imu.hpp) against the cell simulator, which
// computes the IMU's readings by its own route (docs/simulator.md) with biases, a mount rotation
// and a stream delay it is not told about.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

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

}  // namespace
}  // namespace ftid
