// Effect::constantGravitySlope (the compressed tilt search's shortcut, identify/gravity_compression.cpp): every
// registered effect that declares it must satisfy Y(ctx) = Y(ctx, g_S = 0) + sum_j g_S(j) D_j with
// D_j taken once on another sample, checked against the effect's own full regressor on seeded
// random samples (every field of the context random, so a slope that reads anything but g_S fails).
#include <gtest/gtest.h>

#include <optional>
#include <random>
#include <string>

#include "ftid/common/error.hpp"
#include "ftid/effects/model.hpp"

namespace ftid::effects {
namespace {

using Regressor = Eigen::Matrix<double, 6, Eigen::Dynamic>;

SampleContext randomContext(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  auto vec = [&] { return Vec3(u(rng), u(rng), u(rng)); };
  SampleContext c;
  c.t = 10.0 + u(rng);
  c.t_model = c.t + 100.0;
  for (int k = 0; k < c.q.size(); ++k) c.q(k) = u(rng);
  for (int k = 0; k < c.qd.size(); ++k) c.qd(k) = u(rng);
  Eigen::Quaterniond q(u(rng), u(rng), u(rng), u(rng));
  q.normalize();
  c.R_BS = q.toRotationMatrix();
  c.p_BS_B = vec();
  c.w_S = vec();
  c.alpha_S = vec();
  c.a_S = vec();
  c.g_S = 3.0 * vec();
  for (int k = 0; k < 6; ++k) c.wrench_S(k) = 10.0 * u(rng);
  c.imu_acc_S = vec();
  c.imu_w_S = vec();
  c.imu_alpha_S = vec();
  c.temp_degC = 25.0 + 5.0 * u(rng);
  c.has_imu = true;
  c.has_temp = true;
  return c;
}

TEST(ConstantGravitySlope, DeclaringEffectsAreAffineInGravityWithSampleIndependentSlopes) {
  std::mt19937 rng(20261202);
  int checked = 0;
  for (const auto& reg : registeredEffects()) {
    std::optional<Model> composed;
    try {
      composed = Model::fromName(reg.base_name);
    } catch (const ConfigError&) {
      continue;  // needs arguments (e.g. harmonic(q4,2)); none of those declares a constant slope
    }
    const Model& model = *composed;
    const int p = model.numParams();
    for (const auto& e : model.effectList()) {
      if (!e->constantGravitySlope()) continue;
      SCOPED_TRACE(e->name());
      ++checked;
      // Slopes from one random sample.
      SampleContext c0 = randomContext(rng);
      c0.g_S.setZero();
      Regressor Z0 = Regressor::Zero(6, p);
      e->addRegressor(c0, Z0);
      Regressor D[3];
      for (int j = 0; j < 3; ++j) {
        SampleContext cj = c0;
        cj.g_S = Vec3::Unit(j);
        D[j] = Regressor::Zero(6, p);
        e->addRegressor(cj, D[j]);
        D[j] -= Z0;
      }
      EXPECT_GT(D[0].cwiseAbs().sum() + D[1].cwiseAbs().sum() + D[2].cwiseAbs().sum(), 0.0)
          << "declares a gravity slope but does not read g_S";
      for (int s = 0; s < 50; ++s) {
        const SampleContext c = randomContext(rng);
        SampleContext c_level = c;
        c_level.g_S.setZero();
        Regressor full = Regressor::Zero(6, p);
        Regressor split = Regressor::Zero(6, p);
        e->addRegressor(c, full);
        e->addRegressor(c_level, split);
        for (int j = 0; j < 3; ++j) split += c.g_S(j) * D[j];
        const double scale = std::max(1.0, full.cwiseAbs().maxCoeff());
        EXPECT_LE((full - split).cwiseAbs().maxCoeff(), 1e-12 * scale) << "sample " << s;
      }
    }
  }
  EXPECT_GE(checked, 1);  // gravity declares it
}

TEST(ConstantGravitySlope, GravityDeclaresItAndEffectsThatReadMoreThanGravityDoNot) {
  const Model model = Model::fromName("paper+rigid_body+cable+poly(gz,1)");
  for (const auto& e : model.effectList()) {
    SCOPED_TRACE(e->name());
    EXPECT_EQ(e->constantGravitySlope(), e->name() == "gravity");
  }
}

}  // namespace
}  // namespace ftid::effects
