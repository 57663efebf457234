// `ftid identify`'s use of the IMU (identifyContexts with IdentifyRequest::imu; imu_fusion.hpp):
// off is the wrench alone bit for bit; on, the IMU's tilt is fused, and an IMU that disagrees with
// the wrench (or with the configuration) is reported.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <cmath>

#include "ftid/common/error.hpp"
#include "ftid/identify/offline.hpp"
#include "imu_cell.hpp"

namespace ftid {
namespace {

using identify::IdentifyRequest;
using identify::ImuReport;
using ImuUse = IdentifyRequest::ImuUse;

sim::CellSimConfig noisyImuCell(double duration_s) {
  sim::CellSimConfig cfg = test::imuCellConfig(duration_s);
  cfg.imu.delay_s = 0.0;
  cfg.mounting.enabled = false;
  cfg.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  cfg.noise.acc_std = 0.01;
  cfg.noise.gyro_std = 0.002;
  cfg.seed = 23;
  return cfg;
}

void expectSameSets(const params::ParameterSet& a, const params::ParameterSet& b) {
  ASSERT_EQ(a.params.size(), b.params.size());
  for (std::size_t i = 0; i < a.params.size(); ++i) {
    EXPECT_EQ(a.params[i].name, b.params[i].name);
    EXPECT_EQ(a.params[i].value, b.params[i].value) << a.params[i].name;
    EXPECT_EQ(a.params[i].std, b.params[i].std) << a.params[i].name;
  }
  EXPECT_EQ(a.tilt_u_rad, b.tilt_u_rad);
  EXPECT_EQ(a.tilt_v_rad, b.tilt_v_rad);
  EXPECT_EQ(a.tilt_u_std, b.tilt_u_std);
  EXPECT_EQ(a.residual_rms, b.residual_rms);
  EXPECT_EQ(a.provenance.method, b.provenance.method);
}

TEST(ImuIdentify, OffIsTheWrenchAloneBitForBit) {
  const samples::ContextSet cs = test::contextsOf(noisyImuCell(3.0));
  std::vector<effects::SampleContext> without_imu = cs.samples;
  for (auto& c : without_imu) c.has_imu = false;
  for (const std::string model : {"paper+rigid_body", ""}) {
    SCOPED_TRACE(model);
    IdentifyRequest off;
    off.model = model;
    off.imu = ImuUse::kOff;
    IdentifyRequest automatic = off;
    automatic.imu = ImuUse::kAuto;
    ImuReport report;
    const params::ParameterSet a = identify::identifyContexts(cs.samples, off, &report);
    EXPECT_FALSE(report.used);
    // kAuto on a log without IMU columns: the IMU is not consulted, the same result.
    const params::ParameterSet b = identify::identifyContexts(without_imu, automatic, &report);
    EXPECT_FALSE(report.used);
    EXPECT_EQ(report.not_used_reason, "the log has no IMU columns");
    expectSameSets(a, b);
    // And the default request (library callers) is the wrench alone.
    IdentifyRequest plain;
    plain.model = model;
    expectSameSets(a, identify::identifyContexts(cs.samples, plain));
    // kAuto with the IMU changes the answer (the fusion acts).
    if (!model.empty()) {
      const params::ParameterSet c = identify::identifyContexts(cs.samples, automatic, &report);
      EXPECT_TRUE(report.used);
      EXPECT_TRUE(report.fused);
      EXPECT_NE(c.tilt_u_rad, a.tilt_u_rad);
      EXPECT_LT(c.tilt_u_std, a.tilt_u_std);
      EXPECT_EQ(c.provenance.method, "fit+imu");
    }
  }
  IdentifyRequest on;
  on.imu = ImuUse::kOn;
  EXPECT_THROW((void)identify::identifyContexts(without_imu, on), DataError);
}

TEST(ImuIdentify, AgreeingImuIsFusedAndNotWarned) {
  const sim::CellSimConfig cfg = noisyImuCell(3.0);
  const samples::ContextSet cs = test::contextsOf(cfg);
  IdentifyRequest req;
  req.model = "paper+rigid_body";
  req.imu = ImuUse::kOn;
  ImuReport report;
  const params::ParameterSet set = identify::identifyContexts(cs.samples, req, &report);
  ASSERT_TRUE(report.used);
  EXPECT_TRUE(report.fused);
  EXPECT_TRUE(report.warnings.empty()) << report.warnings.front();
  ASSERT_EQ(report.comparisons.size(), 3U);  // tilt, mount (vs configured), delay (vs none)
  EXPECT_NEAR(set.tilt_u_rad, cfg.tilt_u_rad, 4.0 * set.tilt_u_std);
  EXPECT_NEAR(set.tilt_v_rad, cfg.tilt_v_rad, 4.0 * set.tilt_v_std);
  EXPECT_NEAR(report.estimate.acc.bias_mps2.x(), cfg.imu.acc_bias_mps2.x(), 4.0 * report.estimate.acc.bias_std_mps2.x());
}

TEST(ImuIdentify, MisalignedAccelerometerIsReportedAndNotFused) {
  // The accelerometer is rotated by 0.5 deg about x inside the sensor (the gyro is not): its tilt
  // disagrees with the wrench's.
  const samples::ContextSet cs = test::contextsOf(noisyImuCell(3.0));
  std::vector<effects::SampleContext> bad = cs.samples;
  const Mat3 R = Eigen::AngleAxisd(0.5 * test::kDegToRad, Vec3::UnitX()).toRotationMatrix();
  for (auto& c : bad) c.imu_acc_S = R * c.imu_acc_S;
  IdentifyRequest req;
  req.model = "paper+rigid_body";
  req.imu = ImuUse::kAuto;
  ImuReport report;
  const params::ParameterSet set = identify::identifyContexts(bad, req, &report);
  ASSERT_TRUE(report.used);
  EXPECT_FALSE(report.fused);
  ASSERT_FALSE(report.warnings.empty());
  EXPECT_NE(report.warnings.front().find("disagree on the tilt"), std::string::npos) << report.warnings.front();
  // Not fused: the wrench's own answer.
  IdentifyRequest off = req;
  off.imu = ImuUse::kOff;
  const params::ParameterSet w = identify::identifyContexts(bad, off);
  EXPECT_NEAR(set.tilt_u_rad, w.tilt_u_rad, 1e-3 * w.tilt_u_std);
}

// A model with `cable` folds the cable's horizontal pull into its tilt (Model::tiltAbsorbers): its
// tilt is not the base's, so the IMU neither checks it (no "set-up error" warning, which it used to
// raise with chi2 ~ 1e3) nor is fused into it; the report says why, and the tilt is the wrench's.
TEST(ImuIdentify, ACableModelsApparentTiltIsNeitherComparedNorFused) {
  sim::CellSimConfig cfg = noisyImuCell(10.0);  // the paper's 10 s: the apparent tilt is then determined
  cfg.payload.mass_kg = 3.0;
  cfg.cable.enabled = true;
  const samples::ContextSet cs = test::contextsOf(cfg);
  IdentifyRequest req;
  req.model = "paper+rigid_body+cable";
  req.imu = ImuUse::kAuto;
  ImuReport report;
  const params::ParameterSet set = identify::identifyContexts(cs.samples, req, &report);
  ASSERT_TRUE(report.used) << report.not_used_reason;
  EXPECT_FALSE(report.fused);
  EXPECT_TRUE(report.warnings.empty()) << report.warnings.front();
  for (const auto& c : report.comparisons) EXPECT_NE(c.quantity, "tilt") << c.message;
  EXPECT_EQ(report.comparisons.size(), 2U);  // mount and delay are still checked
  EXPECT_NE(report.tilt_not_compared.find("pull of cable"), std::string::npos) << report.tilt_not_compared;
  EXPECT_NE(identify::formatImuReport(report).find("not fused; tilt not compared"), std::string::npos);
  // The apparent tilt is far from the base's (the IMU's is the base's): the check would have failed.
  EXPECT_GT(std::abs(set.tilt_v_rad - cfg.tilt_v_rad), 20.0 * set.tilt_v_std);
  EXPECT_NEAR(report.estimate.acc.tilt_v_rad, cfg.tilt_v_rad, 4.0 * report.estimate.acc.tilt_v_std);
  IdentifyRequest off = req;
  off.imu = ImuUse::kOff;
  const params::ParameterSet w = identify::identifyContexts(cs.samples, off);
  EXPECT_NEAR(set.tilt_v_rad, w.tilt_v_rad, 1e-3 * w.tilt_v_std);  // the same minimum (searched from the IMU's start)
  // Without the cable in the model the same check applies as ever.
  req.model = "paper+rigid_body";
  identify::identifyContexts(cs.samples, req, &report);
  EXPECT_TRUE(report.tilt_not_compared.empty());
  EXPECT_EQ(report.comparisons.front().quantity, "tilt");
}

TEST(ImuIdentify, NoiseFreeImuAgreesWithTheRightSetUpAndStillSeesAHundredthOfADegree) {
  // A noise-free IMU (the simulator's default): its residual-based covariance is ~1e-35, so the
  // estimates' numerical resolution decides; the right set-up raises no warning (it used to read
  // rounding as chi2 ~ 700), and a mount off by 0.01 deg is still reported.
  sim::CellSimConfig cfg = noisyImuCell(3.0);
  cfg.noise.acc_std = 0.0;
  cfg.noise.gyro_std = 0.0;
  IdentifyRequest req;
  req.model = "paper+rigid_body";
  req.imu = ImuUse::kOn;
  ImuReport report;
  (void)identify::identifyContexts(test::contextsOf(cfg).samples, req, &report);
  ASSERT_TRUE(report.used);
  EXPECT_TRUE(report.warnings.empty()) << report.warnings.front();
  cfg.mounting.enabled = true;
  cfg.mounting.rpy_rad = Vec3(0.0, 0.0, 0.01) * test::kDegToRad;
  cfg.mounting.rotate_imu = true;  // the IMU turns with the sensor; the configuration says it does not
  (void)identify::identifyContexts(test::contextsOf(cfg).samples, req, &report);
  bool mount = false;
  for (const auto& w : report.warnings) mount = mount || w.find("disagree on the mount") != std::string::npos;
  EXPECT_TRUE(mount);
}

TEST(ImuIdentify, GyroMountAndDelayAgainstTheWrenchFit) {
  // The sensor is mounted rotated; the IMU is not rotated with it (rotate_imu = false) and its
  // stream lags by 20 ms while the model assumes none: both are reported.
  sim::CellSimConfig cfg = noisyImuCell(3.0);
  cfg.mounting.enabled = true;
  cfg.mounting.rpy_rad = Vec3(0.0, 0.0, 3.0) * test::kDegToRad;
  cfg.mounting.rotate_imu = false;
  cfg.imu.delay_s = 0.02;
  const samples::ContextSet cs = test::contextsOf(cfg);
  IdentifyRequest req;
  req.model = "paper+rigid_body+mounting";
  req.imu = ImuUse::kOn;
  ImuReport report;
  (void)identify::identifyContexts(cs.samples, req, &report);
  ASSERT_TRUE(report.used);
  EXPECT_NEAR(report.estimate.gyro.delay_s, 0.02, 4.0 * report.estimate.gyro.delay_std_s);
  bool mount = false;
  bool delay = false;
  for (const auto& w : report.warnings) {
    mount = mount || w.find("disagree on the mount") != std::string::npos;
    delay = delay || w.find("disagree on the delay") != std::string::npos;
  }
  EXPECT_TRUE(mount);
  EXPECT_TRUE(delay);
  // With the IMU rotated along (the usual sensor), the gyro and the wrench agree on the mount.
  cfg.mounting.rotate_imu = true;
  cfg.imu.delay_s = 0.0;
  (void)identify::identifyContexts(test::contextsOf(cfg).samples, req, &report);
  EXPECT_TRUE(report.warnings.empty()) << report.warnings.front();
  EXPECT_TRUE(report.fused);
}

TEST(ImuIdentify, MountAndDelayAgainstGivenValuesForTheLab) {
  // What the laboratory can call with its own `mounting` / `sensor_delay` answer.
  const sim::CellSimConfig cfg = test::imuCellConfig(3.0);  // mount 1/-2/3 deg, IMU 12 ms late
  sim::CellSimConfig noisy = cfg;
  noisy.noise.acc_std = 0.01;
  noisy.noise.gyro_std = 0.002;
  const identify::GyroMountEstimate g = identify::estimateGyroMount(test::contextsOf(noisy).samples);
  const identify::MountEstimate right{cfg.mounting.rpy_rad, Vec3::Constant(1e-3)};
  const identify::DelayEstimate right_delay{0.012, 5e-4};
  auto c = identify::compareImuMountAndDelay(right, right_delay, g);
  ASSERT_EQ(c.size(), 2U);
  EXPECT_FALSE(c[0].disagrees) << c[0].message;
  EXPECT_FALSE(c[1].disagrees) << c[1].message;
  // A lab answer off by 0.5 deg of yaw and 5 ms: both flagged.
  identify::MountEstimate wrong = right;
  wrong.rpy_rad.z() += 0.5 * test::kDegToRad;
  c = identify::compareImuMountAndDelay(wrong, identify::DelayEstimate{0.017, 5e-4}, g);
  EXPECT_TRUE(c[0].disagrees) << c[0].message;
  EXPECT_TRUE(c[1].disagrees) << c[1].message;
  // No answer: against the configuration (identity, no delay).
  c = identify::compareImuMountAndDelay(std::nullopt, std::nullopt, g);
  EXPECT_TRUE(c[0].disagrees);
  EXPECT_NE(c[0].message.find("configured sensor frame"), std::string::npos) << c[0].message;
  EXPECT_TRUE(c[1].disagrees);
}

}  // namespace
}  // namespace ftid
