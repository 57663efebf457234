// Seed study of the IMU estimators (ftid/identify/imu.hpp): over 40 draws of the simulator's own
// MEMS-grade IMU noise, the estimates scatter around the truth by the standard errors they report
// (seed_study.hpp's claim, with its power check against 1.7x too large or too small).
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "ftid/identify/imu.hpp"
#include "ftid/identify/offline.hpp"
#include "imu_cell.hpp"
#include "seed_study.hpp"

namespace ftid {
namespace {

TEST(ImuStats, SpreadOverSeedsMatchesReportedStandardErrors) {
  sim::CellSimConfig cfg = test::imuCellConfig(3.0);
  const samples::ContextSet clean = test::contextsOf(cfg);
  sim::CellSimConfig noisy = cfg;
  noisy.noise.acc_std = 0.01;
  noisy.noise.gyro_std = 0.002;
  const Mat3 R_true = cfg.mounting.rotation();
  const auto estimator = [&](const std::vector<effects::SampleContext>& ctx) {
    const identify::ImuEstimate e = identify::estimateImu(ctx);
    stats_test::Estimates out;
    out["tilt_u"] = {e.acc.tilt_u_rad, e.acc.tilt_u_std};
    out["tilt_v"] = {e.acc.tilt_v_rad, e.acc.tilt_v_std};
    const char* ax = "xyz";
    // The rotation's error about S's axes (truth 0): R_SM_hat = (I + skew(err)) R_SM_true.
    const Eigen::AngleAxisd err(e.gyro.R_SM * R_true.transpose());
    const Vec3 err_vec = err.angle() * err.axis();
    for (int i = 0; i < 3; ++i) {
      out[std::string("acc_bias_") + ax[i]] = {e.acc.bias_mps2(i), e.acc.bias_std_mps2(i)};
      out[std::string("gyro_bias_") + ax[i]] = {e.gyro.bias_radps(i), e.gyro.bias_std_radps(i)};
      out[std::string("mount_err_") + ax[i]] = {err_vec(i), e.gyro.rotation_std_rad(i)};
    }
    out["imu_delay"] = {e.gyro.delay_s, e.gyro.delay_std_s};
    return out;
  };
  const auto study = stats_test::runSeedStudy(clean.samples, test::simulatorImuNoise(noisy), estimator, 40, 2300);
  stats_test::expectClaim(study, "tilt_u", cfg.tilt_u_rad);
  stats_test::expectClaim(study, "tilt_v", cfg.tilt_v_rad);
  const char* ax = "xyz";
  for (int i = 0; i < 3; ++i) {
    stats_test::expectClaim(study, std::string("acc_bias_") + ax[i], cfg.imu.acc_bias_mps2(i));
    stats_test::expectClaim(study, std::string("gyro_bias_") + ax[i], cfg.imu.gyro_bias_radps(i));
    stats_test::expectClaim(study, std::string("mount_err_") + ax[i], 0.0);
  }
  stats_test::expectClaim(study, "imu_delay", cfg.imu.delay_s);
}

// The fused identification (imu_fusion.hpp): wrench and IMU noise drawn together, the fused
// estimates scatter by their reported standard errors, and the fusion beats the wrench alone on
// the tilt (and through its correlation on the mass and centre of mass).
TEST(ImuStats, FusedFitSpreadMatchesReportedStandardErrors) {
  sim::CellSimConfig cfg = test::imuCellConfig(3.0);
  cfg.mounting.enabled = false;
  cfg.imu.delay_s = 0.0;
  const samples::ContextSet clean = test::contextsOf(cfg);
  sim::CellSimConfig noisy = cfg;
  noisy.noise.wrench_std << 0.05, 0.05, 0.05, 0.01, 0.01, 0.01;
  noisy.noise.acc_std = 0.01;
  noisy.noise.gyro_std = 0.002;
  const auto noise = stats_test::both(stats_test::simulatorWhiteNoise(noisy), test::simulatorImuNoise(noisy));
  const auto estimator = [](identify::IdentifyRequest::ImuUse use) {
    return [use](const std::vector<effects::SampleContext>& ctx) {
      identify::IdentifyRequest req;
      req.model = "paper+rigid_body";
      req.imu = use;
      identify::ImuReport report;
      const params::ParameterSet set = identify::identifyContexts(ctx, req, &report);
      stats_test::Estimates out;
      for (const char* name : {"mass", "com_x", "com_y", "com_z"}) {
        const params::NamedValue* v = set.find(name);
        if (v != nullptr) out[name] = {v->value, v->std};
      }
      out["tilt_u"] = {set.tilt_u_rad, set.tilt_u_std};
      out["tilt_v"] = {set.tilt_v_rad, set.tilt_v_std};
      out["fused"] = {report.fused ? 1.0 : 0.0, 0.0};
      return out;
    };
  };
  using ImuUse = identify::IdentifyRequest::ImuUse;
  const auto fused = stats_test::runSeedStudy(clean.samples, noise, estimator(ImuUse::kOn), 40, 2323);
  const auto wrench = stats_test::runSeedStudy(clean.samples, noise, estimator(ImuUse::kOff), 40, 2323);
  int n_fused = 0;
  for (double f : fused.params.at("fused").values) n_fused += f > 0.5 ? 1 : 0;
  EXPECT_GE(n_fused, 38) << "the IMU and the wrench disagreed in more than 1 in 20 runs";
  // The fused covariance is the wrench fit's, updated: where the wrench fit's own reported error
  // is conservative (com_z here: its spread is 0.68 of the reported, fitModel's Newey-West on a
  // 3 s run), the fused one inherits that; the claim is checked where the wrench fit's holds, and
  // for com_z the fusion must not change the wrench fit's ratio by more than 15 %.
  for (const char* name : {"mass", "com_x", "com_y", "tilt_u", "tilt_v"}) {
    std::printf("wrench alone: %s %s\n", name,
                stats_test::checkSpread(wrench.params.at(name), test::Table2::value(name)).describe().c_str());
    stats_test::expectClaim(fused, name, test::Table2::value(name));
  }
  const double ratio_fused = stats_test::checkSpread(fused.params.at("com_z"), test::Table2::value("com_z")).ratio;
  const double ratio_wrench = stats_test::checkSpread(wrench.params.at("com_z"), test::Table2::value("com_z")).ratio;
  EXPECT_NEAR(ratio_fused / ratio_wrench, 1.0, 0.15) << ratio_fused << " vs " << ratio_wrench;
  for (const char* name : {"tilt_u", "tilt_v"}) {
    const double f = stats_test::checkSpread(fused.params.at(name), 0.0).spread;
    const double w = stats_test::checkSpread(wrench.params.at(name), 0.0).spread;
    std::printf("  %-6s spread fused %.3g, wrench alone %.3g\n", name, f, w);
    EXPECT_LT(f, 0.5 * w) << name;
  }
}

}  // namespace
}  // namespace ftid
