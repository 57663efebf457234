// The paper effects' regressor times theta equals a direct Newton-Euler computation written here
// independently (docs/conventions.md), for seeded random states; model composition and naming.
#include <gtest/gtest.h>

#include <random>

#include "ftid/common/error.hpp"
#include "ftid/effects/model.hpp"

namespace ftid::effects {
namespace {

Mat3 randomRotation(std::mt19937& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
  q.normalize();
  return q.toRotationMatrix();
}

Vec3 randomVec(std::mt19937& rng, double scale) {
  std::uniform_real_distribution<double> u(-scale, scale);
  return Vec3(u(rng), u(rng), u(rng));
}

struct Truth {
  double m;
  Vec3 c;
  Vec3 F0;
  Vec3 T0;
};

/// Direct computation: force of the payload on the sensor and its moment about the S origin.
/// The payload's centre of mass accelerates with a_S (paper model: a_C = a_S); Newton for the
/// payload: F_sensor_on_payload + m g = m a_C, so the payload pushes the sensor with
/// m (g - a_C); that force acts at c, so its moment about S is c x force.
Wrench directWrench(const Truth& tr, const Vec3& g_S, const Vec3& a_S, bool inertia) {
  const Vec3 a_C = inertia ? a_S : Vec3::Zero();
  Vec3 force = tr.m * g_S - tr.m * a_C;
  Vec3 moment(tr.c.y() * force.z() - tr.c.z() * force.y(), tr.c.z() * force.x() - tr.c.x() * force.z(),
              tr.c.x() * force.y() - tr.c.y() * force.x());
  Wrench w;
  w << force + tr.F0, moment + tr.T0;
  return w;
}

Eigen::VectorXd thetaOf(const Model& model, const Truth& tr) {
  Eigen::VectorXd theta(model.numParams());
  const auto& idx = model.paramIndex();
  const char* ax[3] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    theta(idx.column(std::string("f0_") + ax[i])) = tr.F0(i);
    theta(idx.column(std::string("t0_") + ax[i])) = tr.T0(i);
    theta(idx.column(std::string("mass_com_") + ax[i])) = tr.m * tr.c(i);
  }
  theta(idx.column("mass")) = tr.m;
  return theta;
}

TEST(PaperEffects, RegressorTimesThetaEqualsDirectNewtonEuler) {
  std::mt19937 rng(12345);
  for (bool inertia : {false, true}) {
    const Model model = Model::fromName(inertia ? "paper" : "offsets+gravity+tilt");
    for (int trial = 0; trial < 200; ++trial) {
      std::uniform_real_distribution<double> um(0.1, 20.0);
      const Truth tr{um(rng), randomVec(rng, 0.2), randomVec(rng, 2.0), randomVec(rng, 0.2)};
      SampleContext ctx;
      ctx.R_BS = randomRotation(rng);
      ctx.g_S = ctx.R_BS.transpose() * Vec3(0.3, -1.1, -9.7);
      ctx.a_S = randomVec(rng, 5.0);
      ctx.w_S = randomVec(rng, 2.0);  // not used by the paper effects
      ctx.alpha_S = randomVec(rng, 10.0);
      Eigen::Matrix<double, 6, Eigen::Dynamic> Y(6, model.numParams());
      Y.setConstant(123.0);  // computeRegressor must overwrite
      model.computeRegressor(ctx, Y);
      const Wrench expected = directWrench(tr, ctx.g_S, ctx.a_S, inertia);
      const Wrench got = Y * thetaOf(model, tr);
      EXPECT_LT((got - expected).norm(), 1e-12 * (1.0 + expected.norm())) << "trial " << trial;
    }
  }
}

TEST(PaperEffects, SignsAtRestAreNewtonsNotThePapers) {
  // Sensor z down (S = B, level base): a 2 kg payload 0.1 m along +x_S hangs from the sensor.
  const Model model = Model::fromName("paper");
  const Truth tr{2.0, Vec3(0.1, 0.0, 0.0), Vec3::Zero(), Vec3::Zero()};
  SampleContext ctx;  // g_S = (0, 0, -g)
  Eigen::Matrix<double, 6, Eigen::Dynamic> Y(6, model.numParams());
  model.computeRegressor(ctx, Y);
  const Wrench w = Y * thetaOf(model, tr);
  EXPECT_NEAR(w(2), -2.0 * kStandardGravity, 1e-12);  // pulled along gravity
  // c x (m g) = (0.1,0,0) x (0,0,-2g) = (0, +0.2 g, 0)
  EXPECT_NEAR(w(4), 0.2 * kStandardGravity, 1e-12);
  // Accelerating upward (a_S = +z) increases the pull: f = m (g - a)
  ctx.a_S = Vec3(0.0, 0.0, 1.0);
  model.computeRegressor(ctx, Y);
  EXPECT_NEAR((Y * thetaOf(model, tr))(2), -2.0 * (kStandardGravity + 1.0), 1e-12);
}

TEST(Model, PaperAliasExpandsAndCollapses) {
  const Model m = Model::fromName("paper");
  EXPECT_EQ(m.name(), "paper");
  EXPECT_EQ(m.numParams(), 10);
  EXPECT_TRUE(m.estimatesTilt());
  const std::vector<std::string> expected{"f0_x", "f0_y", "f0_z", "t0_x", "t0_y",
                                          "t0_z", "mass", "mass_com_x", "mass_com_y", "mass_com_z"};
  EXPECT_EQ(m.paramIndex().names(), expected);  // parameter order is pinned
  EXPECT_EQ(Model::fromName("offsets + gravity + tilt + linear_inertia").name(), "paper");
  EXPECT_EQ(Model::fromName("paper+gravity").name(), "paper");
}

TEST(Model, RequiredEffectsAreAddedBeforeTheirUser) {
  const Model m = Model::fromName("linear_inertia");
  ASSERT_EQ(m.effectList().size(), 2u);
  EXPECT_EQ(m.effectList()[0]->name(), "gravity");
  EXPECT_EQ(m.name(), "gravity+linear_inertia");
  EXPECT_FALSE(m.estimatesTilt());
}

TEST(Model, UnknownEffectNamesTheKnownOnes) {
  try {
    (void)Model::fromName("paper+warp_drive");
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("warp_drive"), std::string::npos);
    EXPECT_NE(msg.find("linear_inertia"), std::string::npos);
  }
  EXPECT_THROW((void)Model::fromName(""), ConfigError);
  EXPECT_THROW((void)Model::fromName("paper++gravity"), ConfigError);
  EXPECT_THROW((void)Model::fromName("gravity(3)"), ConfigError);
}

TEST(Model, CopyIsIndependentAndWithEffectExtends) {
  const Model a = Model::fromName("offsets+gravity");
  const Model b = a.withEffect("linear_inertia");
  EXPECT_EQ(a.name(), "offsets+gravity");
  EXPECT_EQ(b.name(), "offsets+gravity+linear_inertia");
  EXPECT_THROW((void)b.withEffect("gravity"), ConfigError);
  Model c = b;  // copy
  SampleContext ctx;
  ctx.a_S = Vec3(1.0, 2.0, 3.0);
  Eigen::Matrix<double, 6, Eigen::Dynamic> Yb(6, b.numParams()), Yc(6, c.numParams());
  b.computeRegressor(ctx, Yb);
  c.computeRegressor(ctx, Yc);
  EXPECT_EQ(Yb, Yc);
}

TEST(Registry, RunTimeRegistrationAndListing) {
  const auto list = registeredEffects();
  ASSERT_GE(list.size(), 4u);
  EXPECT_EQ(list[0].base_name, "offsets");
  EXPECT_THROW((void)createEffect("nonexistent"), ConfigError);
  EXPECT_THROW((void)createEffect("offsets(1"), ConfigError);
}

}  // namespace
}  // namespace ftid::effects
