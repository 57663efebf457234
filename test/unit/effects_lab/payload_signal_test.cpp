// payload(s[,n[,ref]]): payload parameters moving with a signal, against a direct Newton-Euler
// computation of a point mass whose position or mass follows the signal (docs/effects.md).
#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include "ftid/common/error.hpp"
#include "ftid/effects/model.hpp"
#ifdef FTID_HAVE_ALLOC_COUNTER
#include "alloc_counter.hpp"
#endif

namespace {

using namespace ftid;
using effects::Model;
using effects::SampleContext;

struct Rng {
  std::mt19937_64 gen{20261203};
  double uni(double a, double b) { return std::uniform_real_distribution<double>(a, b)(gen); }
  Vec3 vec(double s) { return Vec3(uni(-s, s), uni(-s, s), uni(-s, s)); }
};

/// A random sample; rotating = false leaves w_S = alpha_S = 0 (the moving part's inertia, second
/// order in its distance, is not part of the effect: docs/effects.md).
SampleContext randomSample(Rng& rng, bool rotating) {
  SampleContext c;
  const Eigen::Quaterniond q(Eigen::Vector4d(rng.uni(-1, 1), rng.uni(-1, 1), rng.uni(-1, 1), rng.uni(-1, 1)).normalized());
  c.R_BS = q.toRotationMatrix();
  c.g_S = c.R_BS.transpose() * Vec3(0.0, 0.0, -kStandardGravity);
  c.a_S = rng.vec(3.0);
  if (rotating) {
    c.w_S = rng.vec(2.0);
    c.alpha_S = rng.vec(5.0);
  }
  c.t_model = rng.uni(0.0, 100.0);
  return c;
}

/// Force and moment about S of a point mass m at c (S frame), computed directly: Newton's law for
/// the point's acceleration a_S + alpha x c + w x (w x c), the moment of that force about S.
Vec6 pointMassWrench(const SampleContext& ctx, double m, const Vec3& c) {
  const Vec3 a_c = ctx.a_S + ctx.alpha_S.cross(c) + ctx.w_S.cross(ctx.w_S.cross(c));
  const Vec3 f = m * (ctx.g_S - a_c);
  Vec6 w;
  w << f, c.cross(f);
  return w;
}

Vec6 evaluate(const Model& model, const SampleContext& ctx, const Eigen::VectorXd& theta) {
  Eigen::Matrix<double, 6, Eigen::Dynamic> Y(6, model.numParams());
  model.computeRegressor(ctx, Y);
  return Y * theta;
}

Eigen::VectorXd thetaOf(const Model& model, const std::vector<std::pair<std::string, double>>& values) {
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(model.numParams());
  for (const auto& [name, v] : values) {
    const int c = model.paramIndex().column(name);
    EXPECT_GE(c, 0) << name;
    if (c >= 0) theta(c) = v;
  }
  return theta;
}

// A jaw of mass m_j at p0 + grip d: the model's payload (the jaw at grip = 0) plus payload(grip)
// with dmass_com = m_j d gives the point mass's wrench at every grip.
TEST(PayloadSignalEffect, JawMovingWithAColumnMatchesThePointMass) {
  const Model model = Model::fromName("gravity+linear_inertia+rigid_body+payload(grip)");
  const double m_j = 0.3;
  const Vec3 p0(0.01, -0.02, 0.12), d(0.04, 0.005, -0.01);
  const Mat3 I_S0 = m_j * (p0.squaredNorm() * Mat3::Identity() - p0 * p0.transpose());
  const Eigen::VectorXd theta =
      thetaOf(model, {{"mass", m_j}, {"mass_com_x", m_j * p0.x()}, {"mass_com_y", m_j * p0.y()},
                      {"mass_com_z", m_j * p0.z()}, {"i_s_xx", I_S0(0, 0)}, {"i_s_yy", I_S0(1, 1)},
                      {"i_s_zz", I_S0(2, 2)}, {"i_s_xy", I_S0(0, 1)}, {"i_s_xz", I_S0(0, 2)}, {"i_s_yz", I_S0(1, 2)},
                      {"dmass_com_grip_x", m_j * d.x()}, {"dmass_com_grip_y", m_j * d.y()},
                      {"dmass_com_grip_z", m_j * d.z()}});
  const std::vector<std::string> names = {"host_time", "grip"};
  Rng rng;
  for (int trial = 0; trial < 40; ++trial) {
    const bool rotating = trial % 2 == 1;
    SampleContext ctx = randomSample(rng, rotating);
    const double extra[2] = {1.8e9, rng.uni(0.0, 1.0)};
    ctx.extra = extra;
    ctx.extra_names = &names;
    const Vec6 expected = pointMassWrench(ctx, m_j, p0 + extra[1] * d);
    const Vec6 got = evaluate(model, ctx, theta);
    // The force is exact in every motion; the moment too without rotation (with rotation the
    // jaw's moving inertia, second order in its distance, is left out by design).
    EXPECT_LT((got.head<3>() - expected.head<3>()).cwiseAbs().maxCoeff(), 1e-12) << "trial " << trial;
    if (!rotating) {
      EXPECT_LT((got.tail<3>() - expected.tail<3>()).cwiseAbs().maxCoeff(), 1e-12) << "trial " << trial;
    }
  }
}

// A dispensing tool: a point mass at a fixed c whose mass falls with t quadratically, as
// payload(t,2,50): the Taylor coefficients about t = 50 s.
TEST(PayloadSignalEffect, MassChangingWithTimeIsAPolynomialAboutTheReference) {
  const Model model = Model::fromName("gravity+linear_inertia+payload(t,2,50)");
  EXPECT_TRUE(model.contains("payload(t,2,50)"));
  const Vec3 c(0.02, 0.0, 0.15);
  const double m0 = 1.2, a = -0.004, b = 2e-5;  // m(t) = m0 + a t + b t^2
  const double ref = 50.0;
  const double m_ref = m0 + a * ref + b * ref * ref, slope = a + 2.0 * b * ref;
  const Eigen::VectorXd theta = thetaOf(
      model, {{"mass", m_ref}, {"mass_com_x", m_ref * c.x()}, {"mass_com_y", m_ref * c.y()},
              {"mass_com_z", m_ref * c.z()}, {"dmass_t", slope}, {"dmass_com_t_x", slope * c.x()},
              {"dmass_com_t_y", slope * c.y()}, {"dmass_com_t_z", slope * c.z()}, {"dmass_t_2", b},
              {"dmass_com_t_2_x", b * c.x()}, {"dmass_com_t_2_y", b * c.y()}, {"dmass_com_t_2_z", b * c.z()}});
  Rng rng;
  for (int trial = 0; trial < 20; ++trial) {
    const SampleContext ctx = randomSample(rng, false);
    const double m = m0 + a * ctx.t_model + b * ctx.t_model * ctx.t_model;
    const Vec6 expected = pointMassWrench(ctx, m, c);
    EXPECT_LT((evaluate(model, ctx, theta) - expected).cwiseAbs().maxCoeff(), 1e-11) << "trial " << trial;
  }
}

// The smallest mass over the samples (Model::smallestPayloadMass, the physics check of a mass that
// moves with a signal) against m(t) computed directly, for a tool that runs empty at t = 200 s.
TEST(PayloadSignalEffect, SmallestMassOverTheSamplesIsTheDirectMinimum) {
  const Model model = Model::fromName("gravity+linear_inertia+payload(t,2,50)");
  const double m0 = 1.0, a = -0.006, b = 5e-6;  // m(t) = m0 + a t + b t^2: 0 near t = 200 s
  const double ref = 50.0;
  const Eigen::VectorXd theta = thetaOf(model, {{"mass", m0 + a * ref + b * ref * ref},
                                                {"dmass_t", a + 2.0 * b * ref},
                                                {"dmass_t_2", b}});
  for (const double t_end : {150.0, 250.0}) {
    std::vector<SampleContext> ctx(101);
    double direct = 1e9;
    std::size_t at = 0;
    for (std::size_t k = 0; k < ctx.size(); ++k) {
      ctx[k].t_model = t_end * static_cast<double>(k) / 100.0;
      const double m = m0 + a * ctx[k].t_model + b * ctx[k].t_model * ctx[k].t_model;
      if (m < direct) {
        direct = m;
        at = k;
      }
    }
    const auto low = model.smallestPayloadMass(ctx, theta);
    ASSERT_TRUE(low.has_value());
    EXPECT_NEAR(low->mass_kg, direct, 1e-12) << t_end;
    EXPECT_EQ(low->sample, at) << t_end;
    EXPECT_EQ(low->mass_kg > 0.0, t_end < 200.0) << t_end;
  }
  // A constant mass is nobody's business here: no payload(s), no answer.
  const Model still = Model::fromName("paper+rigid_body");
  EXPECT_FALSE(still.smallestPayloadMass(std::vector<SampleContext>(3), Eigen::VectorXd::Ones(still.numParams())));
}

TEST(PayloadSignalEffect, NamesParametersAndErrors) {
  EXPECT_EQ(effects::createEffect("payload(grip)")->name(), "payload(grip)");
  EXPECT_EQ(effects::createEffect("payload( grip , 1 )")->name(), "payload(grip)");
  EXPECT_EQ(effects::createEffect("payload(t,2)")->name(), "payload(t,2)");
  EXPECT_EQ(effects::createEffect("payload(grip,1,0.5)")->name(), "payload(grip,1,0.5)");
  const auto e = effects::createEffect("payload(grip)");
  ASSERT_EQ(e->params().size(), 4u);
  EXPECT_EQ(e->params()[0].name, "dmass_grip");
  EXPECT_EQ(e->params()[3].name, "dmass_com_grip_z");
  EXPECT_EQ(e->signals(), static_cast<std::uint32_t>(effects::kSignalExtraColumn));
  EXPECT_FALSE(e->constantGravitySlope());  // the slope reads the signal
  EXPECT_EQ(effects::createEffect("payload(t)")->signals(), static_cast<std::uint32_t>(effects::kSignalTime));
  for (const char* bad : {"payload", "payload()", "payload(grip,0)", "payload(grip,4)", "payload(grip,1,x)",
                          "payload(grip,1,0,2)"}) {
    try {
      (void)effects::createEffect(bad);
      ADD_FAILURE() << bad << " accepted";
    } catch (const ConfigError& err) {
      EXPECT_NE(std::string(err.what()).find("payload"), std::string::npos) << err.what();
    }
  }
}

TEST(PayloadSignalEffect, RegressorDoesNotAllocate) {
  const Model model = Model::fromName("paper+rigid_body+payload(grip,3)");
  const std::vector<std::string> names = {"grip"};
  const double extra[1] = {0.7};
  Rng rng;
  SampleContext ctx = randomSample(rng, true);
  ctx.extra = extra;
  ctx.extra_names = &names;
  Eigen::Matrix<double, 6, Eigen::Dynamic> Y(6, model.numParams());
#ifdef FTID_HAVE_ALLOC_COUNTER
  test::ScopedAllocationCounter counter;
  model.computeRegressor(ctx, Y);
  EXPECT_EQ(counter.count(), 0u);
#else
  model.computeRegressor(ctx, Y);
#endif
  EXPECT_TRUE(Y.allFinite());
}

}  // namespace
