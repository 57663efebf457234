// What the laboratory finds, compensation applies (issue "every effect compensated"): for every
// effect of the menu, the simulator hides the effect in an excitation run (its own physics, never
// the regressor), the fit identifies the model with that effect, the parameters go through a
// parameter file, and ftidd's compensation code (compensate::Compensator, which the daemon's
// ParameterFileCompensation wraps) compensates
//   run A: the identification run itself            -> contact RMS <= 1.2 x noise on every axis
//   run B: a different motion with an 8 N push     -> contact RMS <= 1.2 x noise outside the push,
//                                                      the push's peak within 3 %.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <unistd.h>

#include "../identify/paper_cell.hpp"
#include "ftid/compensate/compensator.hpp"
#include "ftid/effects/nonlinear.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/identify/fit_parameters.hpp"
#include "test_paths.hpp"

namespace ftid::compensate {
namespace {

struct EffectCase {
  std::string name;   ///< test name
  std::string model;  ///< model identified and compensated
  std::function<void(sim::CellSimConfig&)> hide;  ///< switches the hidden effect on
  /// Adds an effect the simulator has no switch for to the log, computed from the log's own
  /// columns (an independent formulation of the generic effects); may be empty.
  std::function<void(logio::LogData&)> post;
  double rate_hz = 125.0;
};

void PrintTo(const EffectCase& c, std::ostream* os) { *os << c.name; }

constexpr double kForceNoise = 0.05;   // [N]
constexpr double kTorqueNoise = 0.005;  // [Nm]

sim::CellSimConfig baseConfig(std::uint64_t seed, double rate_hz) {
  sim::CellSimConfig cfg = test::paperConfig(false, seed);
  cfg.full_rigid_body = true;
  cfg.rate_hz = rate_hz;
  cfg.noise.wrench_std << kForceNoise, kForceNoise, kForceNoise, kTorqueNoise, kTorqueNoise, kTorqueNoise;
  return cfg;
}

/// Run B: the excitation time-warped (another speed and phase, so other accelerations and poses)
/// with a contact push in the middle.
void makeDifferentRun(sim::CellSimConfig& cfg) {
  const trajectory::FourierTrajectory traj = cfg.trajectory;
  cfg.motion = [traj](double t) {
    constexpr double kSpeed = 0.85;
    constexpr double kShift = 0.7;
    trajectory::TrajectoryPoint p = traj.evaluate(kSpeed * t + kShift);
    p.qd *= kSpeed;
    p.qdd *= kSpeed * kSpeed;
    return p;
  };
  cfg.duration_s = 8.0;
  cfg.contact.enabled = true;
  cfg.contact.t_start_s = 3.0;
  cfg.contact.t_end_s = 5.0;
  cfg.contact.force_B = Vec3(0.0, 0.0, -8.0);
}

logio::LogData simulate(const EffectCase& c, sim::CellSimConfig cfg) {
  c.hide(cfg);
  logio::LogData log = sim::CellSim(cfg).run();
  if (c.post) c.post(log);
  return log;
}

std::string scratchPath(const std::string& name) {
  return ftid::test::binaryPath("/compensation_by_effect_") + name + "_" + std::to_string(::getpid()) + ".yaml";
}

class CompensationByEffect : public ::testing::TestWithParam<EffectCase> {};

TEST_P(CompensationByEffect, IdentifiedModelCompensatesToTheNoiseFloorDuringMotion) {
  const EffectCase& c = GetParam();
  const effects::Model model = effects::Model::fromName(c.model);
  const Vec6 noise = (Vec6() << kForceNoise, kForceNoise, kForceNoise, kTorqueNoise, kTorqueNoise, kTorqueNoise).finished();

  // Identify on run A, through a parameter file as ftidd would load it.
  const sim::CellSimConfig cfg_a = baseConfig(101, c.rate_hz);
  const logio::LogData log_a = simulate(c, cfg_a);
  const samples::ContextSet ctx_a = samples::buildContexts(log_a, *cfg_a.robot);
  const identify::FitResult fit = identify::fitModel(model, ctx_a.samples);
  SCOPED_TRACE(::testing::Message() << "fit residual RMS " << fit.residual_rms.transpose());
  const std::string path = scratchPath(c.name);
  params::writeParameterFile(path, identify::toParameterSet(fit));
  const params::ParameterSet set = params::readParameterFile(path);
  std::remove(path.c_str());
  std::remove((path + ".bak").c_str());
  const effects::Model loaded = effects::Model::fromName(set.model);
  ASSERT_EQ(loaded.name(), model.name());

  // Run A.
  {
    Compensator comp(loaded, params::thetaFor(loaded, set), params::nonlinearFor(loaded, set));
    Vec6 sse = Vec6::Zero();
    Vec6 raw = Vec6::Zero();
    int n = 0;
    for (const auto& ctx : ctx_a.samples) {
      Wrench contact;
      const Status st = comp.compute(ctx, &contact, nullptr);
      if (st == Status::kNotReady) continue;
      ASSERT_EQ(st, Status::kOk) << "t = " << ctx.t;
      sse += contact.cwiseAbs2();
      raw += ctx.wrench_S.cwiseAbs2();
      ++n;
    }
    ASSERT_GT(n, static_cast<int>(ctx_a.size()) * 3 / 4);
    const Vec6 rms = (sse / n).cwiseSqrt();
    for (int a = 0; a < 6; ++a) {
      EXPECT_LE(rms(a), 1.2 * noise(a)) << "run A, " << kWrenchAxisNames[a] << " (raw RMS "
                                        << std::sqrt(raw(a) / n) << ")";
    }
  }

  // Run B: another motion, another noise seed, a push.
  sim::CellSimConfig cfg_b = baseConfig(202, c.rate_hz);
  makeDifferentRun(cfg_b);
  const logio::LogData log_b = simulate(c, cfg_b);
  const samples::ContextSet ctx_b = samples::buildContexts(log_b, *cfg_b.robot);
  const int cfx = log_b.extraIndex("contact_fx");
  ASSERT_GE(cfx, 0);
  Compensator comp(loaded, params::thetaFor(loaded, set), params::nonlinearFor(loaded, set));
  Vec6 sse = Vec6::Zero();
  int n = 0;
  int n_free = 0;
  double peak_truth = 0.0;
  double peak_seen = 0.0;
  for (std::size_t i = 0; i < ctx_b.size(); ++i) {
    Wrench contact;
    const Status st = comp.compute(ctx_b.samples[i], &contact, nullptr);
    if (st == Status::kNotReady) continue;
    ASSERT_EQ(st, Status::kOk);
    // The output belongs to the reading at comp.outputTime() (a negative delay outputs late).
    const std::size_t k = static_cast<std::size_t>(std::lround((comp.outputTime() - ctx_b.samples[0].t) * c.rate_hz));
    ASSERT_LT(k, ctx_b.size());
    Wrench truth;
    for (int a = 0; a < 6; ++a) truth(a) = log_b.extra_columns[static_cast<std::size_t>(cfx + a)][k];
    ++n;
    if (truth.isZero()) {  // the contact RMS where there is no contact; the push is checked by its peak
      sse += contact.cwiseAbs2();
      ++n_free;
    }
    if (std::abs(truth.head<3>().norm()) > peak_truth) {
      peak_truth = truth.head<3>().norm();
      peak_seen = contact.head<3>().norm();
    }
  }
  ASSERT_GT(n, static_cast<int>(ctx_b.size()) * 3 / 4);
  ASSERT_GT(n_free, n / 2);
  const Vec6 rms = (sse / n_free).cwiseSqrt();
  for (int a = 0; a < 6; ++a) {
    EXPECT_LE(rms(a), 1.2 * noise(a)) << "run B, " << kWrenchAxisNames[a];
  }
  EXPECT_NEAR(peak_truth, 8.0, 0.05);  // sampled near the peak
  EXPECT_NEAR(peak_seen, peak_truth, 0.03 * peak_truth);
}

// An fx disturbance periodic in the wrist-3 angle, and a temperature-squared drift on every axis,
// written from the log's own columns.
void addHarmonicQ6(logio::LogData& log) {
  for (auto& s : log.samples) {
    s.wrench_S(0) += 0.6 * std::sin(s.q(5)) + 0.3 * std::cos(s.q(5));
    s.wrench_S(4) += 0.04 * std::sin(s.q(5));
  }
}
void addTemperatureSquared(logio::LogData& log) {
  for (auto& s : log.samples) {
    const double d = s.temp_degC - 25.0;
    for (int a = 0; a < 3; ++a) s.wrench_S(a) += (0.01 * (a + 1)) * d * d;
    s.wrench_S(5) += 0.002 * d * d;
  }
}

Mat6 symmetricCrosstalk() {
  // The identifiable part of a calibration error (docs/effects.md, crosstalk): equal fz and tz
  // gains and a symmetric force-to-moment block; the simulator's default matrix otherwise.
  Mat6 E = sim::CrosstalkSwitch::defaultMatrix();
  E(5, 5) = E(2, 2);
  const Mat3 E_tf = E.bottomLeftCorner<3, 3>();
  E.bottomLeftCorner<3, 3>() = 0.5 * (E_tf + E_tf.transpose());
  return E;
}

const EffectCase kCases[] = {
    {"rigid_body", "paper+rigid_body", [](sim::CellSimConfig&) {}, nullptr},
    {"cable", "paper+rigid_body+cable", [](sim::CellSimConfig& c) { c.cable.enabled = true; }, nullptr},
    {"temperature_drift", "paper+rigid_body+temperature_drift",
     [](sim::CellSimConfig& c) { c.temperature_drift.enabled = true; }, nullptr},
    {"time_drift", "paper+rigid_body+time_drift", [](sim::CellSimConfig& c) { c.time_drift.enabled = true; },
     nullptr},
    {"sensor_delay_12ms_125Hz", "paper+rigid_body+sensor_delay",
     [](sim::CellSimConfig& c) {
       c.sensor_delay.enabled = true;
       c.sensor_delay.tau_s = 0.012;
     },
     nullptr},
    {"sensor_delay_12ms_500Hz", "paper+rigid_body+sensor_delay",
     [](sim::CellSimConfig& c) {
       c.sensor_delay.enabled = true;
       c.sensor_delay.tau_s = 0.012;
     },
     nullptr, 500.0},
    {"sensor_delay_150ms", "paper+rigid_body+sensor_delay",
     [](sim::CellSimConfig& c) {
       c.sensor_delay.enabled = true;
       c.sensor_delay.tau_s = 0.150;
     },
     nullptr},
    {"sensor_delay_negative", "paper+rigid_body+sensor_delay",
     [](sim::CellSimConfig& c) {
       c.sensor_delay.enabled = true;
       c.sensor_delay.tau_s = -0.040;
     },
     nullptr},
    {"crosstalk", "paper+rigid_body+crosstalk",
     [](sim::CellSimConfig& c) {
       // 31 calibration parameters need wrenches on every axis: the paper's light tool (centre of
       // mass 5 cm on z) leaves the moment columns undetermined (standard errors ~ 0.3), so this
       // case carries a heavier tool with an offset centre of mass, sampled at 500 Hz.
       c.payload.mass_kg = 3.0;
       c.payload.p_SC_S = Vec3(0.08, -0.06, 0.12);
       c.payload.I_C_S = Vec3(0.02, 0.03, 0.025).asDiagonal();
       c.crosstalk.enabled = true;
       c.crosstalk.E = symmetricCrosstalk();
     },
     nullptr, 500.0},
    {"mounting", "paper+rigid_body+mounting",
     [](sim::CellSimConfig& c) {
       // The sensor is mounted 3 deg about z and 1 deg about x off the configured X_FS (identity).
       c.R_FS = (Eigen::AngleAxisd(3.0 * test::kDegToRad, Vec3::UnitZ()) *
                 Eigen::AngleAxisd(1.0 * test::kDegToRad, Vec3::UnitX())).toRotationMatrix();
     },
     nullptr},
    {"harmonic_q6", "paper+rigid_body+harmonic(q6,1)", [](sim::CellSimConfig&) {}, addHarmonicQ6},
    {"poly_temp", "paper+rigid_body+poly(temp,2)", [](sim::CellSimConfig&) {}, addTemperatureSquared},
};

INSTANTIATE_TEST_SUITE_P(Menu, CompensationByEffect, ::testing::ValuesIn(kCases),
                         [](const ::testing::TestParamInfo<EffectCase>& p) { return p.param.name; });

}  // namespace
}  // namespace ftid::compensate
