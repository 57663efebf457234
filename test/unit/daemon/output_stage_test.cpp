// ftidd's output stage: the contact wrench in the sensor, tool or base frame, and the low-pass.
#include <gtest/gtest.h>

#include <cmath>

#include "ftid/common/error.hpp"
#include "ftid/config/daemon_config.hpp"
#include "ftid/daemon/output_stage.hpp"
#include "test_paths.hpp"

namespace ftid::daemon {
namespace {

Mat3 rot(double angle, const Vec3& axis) { return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix(); }

TEST(OutputStage, ToolFrameIsTheWrenchOfTheContactForceAboutTheToolOrigin) {
  // Independent formulation: a force F (in S) applied at the point p (in S). In S the contact
  // wrench is [F; p x F] (docs/conventions.md). In the tool frame T (origin p_ST, axes R_ST) it is
  // the same force about the T origin: [R_ST^T F; R_ST^T ((p - p_ST) x F)].
  OutputStageConfig cfg;
  cfg.frame = OutputFrame::kTool;
  cfg.R_ST = rot(0.7, Vec3(1, -2, 0.5));
  cfg.p_ST_S = Vec3(0.02, -0.01, 0.18);
  OutputStage stage(cfg);
  const Vec3 F(3.0, -4.0, 12.0);
  const Vec3 p(0.05, 0.03, 0.20);
  Wrench contact_S;
  contact_S << F, p.cross(F);
  const Wrench out = stage.process(contact_S, rot(1.1, Vec3(0, 1, 1)), true);
  const Vec3 f_T = cfg.R_ST.transpose() * F;
  const Vec3 t_T = cfg.R_ST.transpose() * (p - cfg.p_ST_S).cross(F);
  EXPECT_LT((out.head<3>() - f_T).norm(), 1e-12);
  EXPECT_LT((out.tail<3>() - t_T).norm(), 1e-12);
  // A force through the tool origin has no moment there.
  Wrench through;
  through << F, cfg.p_ST_S.cross(F);
  EXPECT_LT(stage.process(through, Mat3::Identity(), true).tail<3>().norm(), 1e-12);
}

TEST(OutputStage, BaseFrameRotatesIntoTheBaseAndSensorFrameIsUnchanged) {
  const Mat3 R_BS = rot(2.0, Vec3(0.3, 0.4, -1));
  Wrench w;
  w << 1, 2, 3, 0.4, 0.5, 0.6;
  OutputStageConfig cfg;
  cfg.frame = OutputFrame::kBase;
  const Wrench b = OutputStage(cfg).process(w, R_BS, true);
  EXPECT_LT((b.head<3>() - R_BS * w.head<3>()).norm(), 1e-12);
  EXPECT_LT((b.tail<3>() - R_BS * w.tail<3>()).norm(), 1e-12);
  // The magnitude of a force does not depend on the frame it is written in.
  EXPECT_NEAR(b.head<3>().norm(), w.head<3>().norm(), 1e-12);
  EXPECT_EQ(OutputStage().process(w, R_BS, true), w);
}

/// Steady-state amplitude of the filter's response to a sine of frequency f.
double gainAt(double f, double fc, double rate) {
  OutputStageConfig cfg;
  cfg.lowpass_hz = fc;
  cfg.sample_rate_hz = rate;
  OutputStage stage(cfg);
  // Least-squares fit of y = a sin + b cos over the second half (after the transient): the
  // amplitude sqrt(a^2 + b^2), exact also when the samples miss the peaks.
  const int n = static_cast<int>(rate * std::max(20.0 / f, 40.0 / fc));
  Eigen::Matrix2d AtA = Eigen::Matrix2d::Zero();
  Eigen::Vector2d Aty = Eigen::Vector2d::Zero();
  for (int i = 0; i < n; ++i) {
    const double ph = 2.0 * M_PI * f * i / rate;
    Wrench w = Wrench::Zero();
    w(2) = std::sin(ph);
    const double y = stage.process(w, Mat3::Identity(), true)(2);
    if (i > n / 2) {
      const Eigen::Vector2d row(std::sin(ph), std::cos(ph));
      AtA += row * row.transpose();
      Aty += row * y;
    }
  }
  return AtA.ldlt().solve(Aty).norm();
}

TEST(OutputStage, LowPassIsASecondOrderButterworth) {
  const double rate = 500.0, fc = 10.0;
  // Analog Butterworth magnitude 1/sqrt(1 + (f/fc)^4); the bilinear transform is exact at fc
  // (pre-warped) and close well below Nyquist.
  EXPECT_NEAR(gainAt(fc, fc, rate), 1.0 / std::sqrt(2.0), 0.005);
  EXPECT_NEAR(gainAt(1.0, fc, rate), 1.0 / std::sqrt(1.0 + std::pow(0.1, 4)), 0.005);
  const double g100 = gainAt(100.0, fc, rate);
  EXPECT_NEAR(g100, 1.0 / std::sqrt(1.0 + std::pow(10.0, 4)), 0.004);  // -40 dB/decade: ~0.01
  EXPECT_LT(g100, 0.012);
  // Near Nyquist only the pre-warped bilinear transform keeps the gain 1/sqrt(2) at the cut-off.
  EXPECT_NEAR(gainAt(40.0, 40.0, 125.0), 1.0 / std::sqrt(2.0), 0.002);
}

TEST(OutputStage, StartsAtTheFirstValueAndResetsOnInvalidCycles) {
  OutputStageConfig cfg;
  cfg.lowpass_hz = 5.0;
  cfg.sample_rate_hz = 125.0;
  OutputStage stage(cfg);
  Wrench w;
  w << 7, -3, 2, 0.1, 0.2, -0.3;
  // A constant input is passed through from the first cycle (no start-up transient).
  for (int i = 0; i < 5; ++i) EXPECT_LT((stage.process(w, Mat3::Identity(), true) - w).norm(), 1e-12);
  EXPECT_EQ(stage.process(w, Mat3::Identity(), false), Wrench::Zero());
  const Wrench w2 = -w;
  EXPECT_LT((stage.process(w2, Mat3::Identity(), true) - w2).norm(), 1e-12);
  // A step then rises monotonically-ish towards the new value (filtered, not passed through).
  const Wrench y = stage.process(w, Mat3::Identity(), true);
  EXPECT_GT((y - w).norm(), 0.5 * (w2 - w).norm());
}

TEST(OutputStage, RejectsACutOffAboveTheLoopsRangeAndUnknownFrames) {
  OutputStageConfig cfg;
  cfg.sample_rate_hz = 125.0;
  cfg.lowpass_hz = 60.0;
  EXPECT_THROW(OutputStage{cfg}, ConfigError);
  cfg.lowpass_hz = -1.0;
  EXPECT_THROW(OutputStage{cfg}, ConfigError);
  EXPECT_THROW(parseOutputFrame("tcp"), ConfigError);
  EXPECT_EQ(parseOutputFrame("tool"), OutputFrame::kTool);
}

TEST(OutputStage, ConfigNamesTheKeyOfABadOutputSetting) {
  const std::string base = "robot: {urdf_path: " + ftid::test::sourceDir() +
                           "/config/ur10.urdf, rtde_frequency_hz: 125}\n"
                           "sensor: {dbc_path: " + ftid::test::sourceDir() + "/config/ftsensor.dbc}\n";
  const config::DaemonConfig ok =
      config::parseDaemonConfig(base + "output: {frame: tool, tool_xyz: [0, 0, 0.2], lowpass_hz: 20}\n", "ok.yaml", "");
  EXPECT_EQ(ok.output.frame, "tool");
  EXPECT_DOUBLE_EQ(ok.output.lowpass_hz, 20.0);
  for (const auto& [text, key] : {std::pair<std::string, std::string>{"output: {lowpass_hz: 60}\n", "output.lowpass_hz"},
                                  {"output: {frame: tcp}\n", "output.frame"}}) {
    try {
      config::parseDaemonConfig(base + text, "bad.yaml", "");
      ADD_FAILURE() << "expected ConfigError for " << text;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("bad.yaml:3:"), std::string::npos) << e.what();  // line:column
      EXPECT_NE(std::string(e.what()).find(": key '" + key + "'"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace ftid::daemon
