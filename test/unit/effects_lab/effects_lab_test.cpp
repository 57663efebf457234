// Each laboratory effect's regressor times its parameters against an independent, direct
// computation of the same physics (docs/effects.md).
#include <gtest/gtest.h>

#include <random>

#include "ftid/common/error.hpp"
#include "ftid/effects/cable.hpp"
#include "ftid/effects/expression.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/effects/nonlinear.hpp"
#include "ftid/effects/rigid_body.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/model/frames.hpp"
#ifdef FTID_HAVE_ALLOC_COUNTER
#include "alloc_counter.hpp"
#endif

namespace {

using namespace ftid;
using effects::Model;
using effects::SampleContext;

struct Rng {
  std::mt19937_64 gen{12345};
  double uni(double a, double b) { return std::uniform_real_distribution<double>(a, b)(gen); }
  Vec3 vec(double s) { return Vec3(uni(-s, s), uni(-s, s), uni(-s, s)); }
  Mat3 rotation() {
    return Eigen::Quaterniond(Eigen::Vector4d(uni(-1, 1), uni(-1, 1), uni(-1, 1), uni(-1, 1)).normalized())
        .toRotationMatrix();
  }
};

SampleContext randomContext(Rng& rng) {
  SampleContext c;
  c.t = rng.uni(0.0, 10.0);
  c.t_model = rng.uni(-10.0, 3600.0);  // the model's time: its own origin, not the sample time
  for (int j = 0; j < 6; ++j) {
    c.q(j) = rng.uni(-3.0, 3.0);
    c.qd(j) = rng.uni(-1.0, 1.0);
  }
  c.R_BS = rng.rotation();
  c.p_BS_B = rng.vec(1.0);
  c.w_S = rng.vec(2.0);
  c.alpha_S = rng.vec(5.0);
  c.a_S = rng.vec(3.0);
  c.g_S = c.R_BS.transpose() * Vec3(0.0, 0.0, -kStandardGravity);
  c.temp_degC = rng.uni(20.0, 35.0);
  c.has_temp = true;
  for (int a = 0; a < 6; ++a) {
    c.wrench_model_S(a) = rng.uni(-20.0, 20.0);
  }
  return c;
}

Vec6 evaluate(const Model& m, const SampleContext& c, const Eigen::VectorXd& theta) {
  Eigen::Matrix<double, 6, Eigen::Dynamic> Y(6, m.numParams());
  m.computeRegressor(c, Y);
  return Y * theta;
}

void setParam(const Model& m, Eigen::VectorXd& theta, const std::string& name, double v) {
  const int c = m.paramIndex().column(name);
  ASSERT_GE(c, 0) << name;
  theta(c) = v;
}

TEST(RigidBodyEffect, MatchesNewtonEulerWithInertiaAboutCom) {
  Rng rng;
  const Model model = Model::fromName("paper+rigid_body");
  const double m = 1.7;
  const Vec3 c(0.02, -0.015, 0.08);
  Mat3 I_C;
  I_C << 0.011, 0.001, -0.0005, 0.001, 0.009, 0.0008, -0.0005, 0.0008, 0.006;
  const Vec3 F0(0.3, -0.2, 0.5), T0(0.01, 0.02, -0.03);
  const Mat3 I_S = I_C + m * (c.squaredNorm() * Mat3::Identity() - c * c.transpose());
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(model.numParams());
  setParam(model, theta, "f0_x", F0.x());
  setParam(model, theta, "f0_y", F0.y());
  setParam(model, theta, "f0_z", F0.z());
  setParam(model, theta, "t0_x", T0.x());
  setParam(model, theta, "t0_y", T0.y());
  setParam(model, theta, "t0_z", T0.z());
  setParam(model, theta, "mass", m);
  setParam(model, theta, "mass_com_x", m * c.x());
  setParam(model, theta, "mass_com_y", m * c.y());
  setParam(model, theta, "mass_com_z", m * c.z());
  const Vec6 iv = effects::inertiaVector(I_S);
  for (int k = 0; k < 6; ++k) setParam(model, theta, effects::kInertiaParamNames[k], iv(k));
  for (int trial = 0; trial < 50; ++trial) {
    const SampleContext ctx = randomContext(rng);
    // Newton-Euler about the centre of mass (docs/conventions.md), computed directly.
    const Vec3 a_C = ctx.a_S + ctx.alpha_S.cross(c) + ctx.w_S.cross(ctx.w_S.cross(c));
    const Vec3 f = m * (ctx.g_S - a_C);
    const Vec3 t = c.cross(f) - I_C * ctx.alpha_S - ctx.w_S.cross(I_C * ctx.w_S);
    Vec6 expected;
    expected << f + F0, t + T0;
    const Vec6 got = evaluate(model, ctx, theta);
    EXPECT_LT((got - expected).cwiseAbs().maxCoeff(), 1e-12) << got.transpose() << "\n" << expected.transpose();
  }
}

TEST(RigidBodyEffect, InertiaAboutComRoundTripAndValidity) {
  const double m = 2.0;
  const Vec3 c(0.01, 0.02, 0.1);
  Mat3 I_C = Mat3::Zero();
  I_C.diagonal() << 0.02, 0.03, 0.04;
  const Mat3 I_S = I_C + m * (c.squaredNorm() * Mat3::Identity() - c * c.transpose());
  Eigen::Matrix<double, 10, 1> p;
  p << m, m * c, effects::inertiaVector(I_S);
  Eigen::Matrix<double, 10, 10> cov = Eigen::Matrix<double, 10, 10>::Zero();
  cov(4, 4) = 1e-8;  // var(i_s_xx): passes straight to i_c_xx
  const auto r = effects::inertiaAboutCom(p, cov);
  EXPECT_LT((effects::inertiaMatrix(r.value) - I_C).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NEAR(r.std(0), 1e-4, 1e-9);
  EXPECT_NEAR(r.std(1), 0.0, 1e-9);
  EXPECT_TRUE(r.positive_definite);
  EXPECT_TRUE(r.triangle_inequalities);
  // A rod-like tensor violating the triangle inequality (0.1 > 0.01 + 0.02).
  Mat3 bad = Mat3::Zero();
  bad.diagonal() << 0.01, 0.02, 0.1;
  p.tail<6>() = effects::inertiaVector(bad + m * (c.squaredNorm() * Mat3::Identity() - c * c.transpose()));
  const auto rb = effects::inertiaAboutCom(p, Eigen::Matrix<double, 10, 10>::Zero());
  EXPECT_TRUE(rb.positive_definite);
  EXPECT_FALSE(rb.triangle_inequalities);
  EXPECT_FALSE(rb.valid_within_uncertainty);
  // Negative principal moment.
  bad.diagonal() << -0.01, 0.02, 0.02;
  p.tail<6>() = effects::inertiaVector(bad + m * (c.squaredNorm() * Mat3::Identity() - c * c.transpose()));
  EXPECT_FALSE(effects::inertiaAboutCom(p, Eigen::Matrix<double, 10, 10>::Zero()).positive_definite);
}

/// The spring wrench computed geometrically in the base frame (rest length 0).
Vec6 springWrench(const SampleContext& ctx, double k, const Vec3& a_S, const Vec3& anchor_B) {
  const Vec3 p_attach_B = ctx.p_BS_B + ctx.R_BS * a_S;
  const Vec3 f_B = k * (anchor_B - p_attach_B);
  const Vec3 f_S = ctx.R_BS.transpose() * f_B;
  Vec6 w;
  w << f_S, a_S.cross(f_S);
  return w;
}

TEST(CableEffect, MatchesSpringWhenAnchorPullIsVertical) {
  // With the anchor pull along z_B the linear parametrisation needs no help from the tilt.
  Rng rng;
  const Model model = Model::fromName("paper+cable");
  const double k = 12.0;
  const Vec3 a(0.03, -0.02, 0.11), anchor(0.0, 0.0, 1.6);
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(model.numParams());
  setParam(model, theta, effects::kCableStiffnessParam, k);
  for (int i = 0; i < 3; ++i) setParam(model, theta, effects::kCableAttachParams[i], k * a(i));
  setParam(model, theta, "cable_kp_z", k * anchor.z());
  const char* ax = "xyz";
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      setParam(model, theta, std::string("cable_m_") + ax[i] + ax[j], a(i) * k * anchor(j));
    }
  }
  for (int trial = 0; trial < 50; ++trial) {
    const SampleContext ctx = randomContext(rng);
    const Vec6 expected = springWrench(ctx, k, a, anchor);
    EXPECT_LT((evaluate(model, ctx, theta) - expected).cwiseAbs().maxCoeff(), 1e-12);
  }
}

TEST(CableEffect, ArbitraryAnchorIsFittedExactlyWithTiltAndStiffnessIsIdentifiable) {
  // Payload (gravity at a tilted base, linear inertia) plus a spring toward an anchor with a
  // horizontal offset: paper+cable must reproduce it exactly (the horizontal pull is absorbed by
  // the tilt), and k and k*a are identified.
  Rng rng;
  const double m = 1.2, k = 4.0, u = 0.03, v = -0.02;  // horizontal pull 3 N < weight 11.8 N
  const Vec3 c(0.01, 0.0, 0.06), a(0.02, 0.04, 0.09), anchor(-0.7, -0.3, 1.4);
  std::vector<SampleContext> ctxs;
  for (int i = 0; i < 400; ++i) {
    SampleContext ctx = randomContext(rng);
    ctx.g_S = ctx.R_BS.transpose() * model::gravityInBase(u, v);
    const Vec3 f = m * (ctx.g_S - ctx.a_S);
    Vec6 w;
    w << f, c.cross(f);
    ctx.wrench_S = w + springWrench(ctx, k, a, anchor);
    ctxs.push_back(ctx);
  }
  const Model model = Model::fromName("paper+cable");
  identify::FitOptions opt;
  opt.axis_weights = false;
  const auto fit = identify::fitModel(model, ctxs, opt);
  EXPECT_LT(fit.residual_rms.maxCoeff(), 1e-8);
  EXPECT_NEAR(fit.value(effects::kCableStiffnessParam), k, 1e-6);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(fit.value(effects::kCableAttachParams[i]), k * a(i), 1e-6);
  EXPECT_NEAR(fit.value("mass"), m, 1e-8);
}

TEST(DriftEffects, TemperatureAndTimeAreLinearOffsets) {
  Rng rng;
  const Model model = Model::fromName("offsets+temperature_drift(20)+time_drift");
  EXPECT_EQ(model.name(), "offsets+temperature_drift(20)+time_drift");
  Eigen::VectorXd theta = Eigen::VectorXd::Random(model.numParams());
  const auto idx = [&](const std::string& n) { return theta(model.paramIndex().column(n)); };
  const char* fa[6] = {"x", "y", "z", "x", "y", "z"};
  for (int trial = 0; trial < 20; ++trial) {
    const SampleContext ctx = randomContext(rng);
    const Vec6 got = evaluate(model, ctx, theta);
    for (int a = 0; a < 6; ++a) {
      const std::string pre = a < 3 ? "f0" : "t0";
      const double expected = idx(pre + "_" + fa[a]) + idx(pre + "_dtemp_" + fa[a]) * (ctx.temp_degC - 20.0) +
                              idx(pre + "_dt_" + fa[a]) * ctx.t_model;
      EXPECT_NEAR(got(a), expected, 1e-12);
    }
  }
  EXPECT_NE(effects::createEffect("temperature_drift")->name().find("temperature_drift"), std::string::npos);
}

TEST(SensorDelayEffect, IsAnExactShiftWithoutColumns) {
  const Model model = Model::fromName("paper+sensor_delay");
  EXPECT_TRUE(model.estimatesDelay());
  EXPECT_FALSE(model.estimatesMounting());
  EXPECT_EQ(model.numParams(), Model::fromName("paper").numParams());
}

TEST(Nonlinear, KinematicsAtInterpolatesBetweenTheBracketingSamples) {
  // Samples of linear functions of time at irregular times: linear interpolation is exact.
  std::vector<SampleContext> series;
  for (double t : {0.0, 0.01, 0.025, 0.03, 0.05}) {
    SampleContext c;
    c.t = t;
    c.w_S = Vec3(1.0 + 2.0 * t, -3.0 * t, 0.5);
    c.a_S = Vec3(4.0 * t, 1.0, -t);
    c.q(5) = 10.0 * t;
    c.wrench_S.setConstant(100.0 * t);  // a reading field: never interpolated
    series.push_back(c);
  }
  auto at = [&](int i) -> const SampleContext& { return series[static_cast<std::size_t>(i)]; };
  for (double t : {0.0, 0.004, 0.0123, 0.027, 0.05}) {
    SampleContext out;
    out.wrench_S.setConstant(-7.0);
    ASSERT_TRUE(effects::kinematicsAt(at, 5, t, &out)) << t;
    EXPECT_NEAR(out.w_S.x(), 1.0 + 2.0 * t, 1e-12);
    EXPECT_NEAR(out.w_S.y(), -3.0 * t, 1e-12);
    EXPECT_NEAR(out.a_S.z(), -t, 1e-12);
    EXPECT_NEAR(out.q(5), 10.0 * t, 1e-12);
    EXPECT_EQ(out.wrench_S(0), -7.0);
  }
  SampleContext out;
  EXPECT_FALSE(effects::kinematicsAt(at, 5, -0.001, &out));
  EXPECT_FALSE(effects::kinematicsAt(at, 5, 0.0501, &out));
  EXPECT_FALSE(effects::kinematicsAt(at, 0, 0.0, &out));
}

TEST(Nonlinear, MountingRotationIsRzRyRx) {
  const Vec3 rpy(0.3, -0.2, 1.1);
  const Mat3 expected = (Eigen::AngleAxisd(rpy.z(), Vec3::UnitZ()) * Eigen::AngleAxisd(rpy.y(), Vec3::UnitY()) *
                         Eigen::AngleAxisd(rpy.x(), Vec3::UnitX()))
                            .toRotationMatrix();
  EXPECT_LT((effects::mountingRotation(rpy) - expected).norm(), 1e-14);
}

TEST(Nonlinear, ApplyMountingReexpressesTheKinematicsInTheTrueFrame) {
  // Physical vectors in the base frame, seen from a frame M = S rotated by R_SM.
  Rng rng;
  const Mat3 R_BS = rng.rotation();
  const Mat3 R_SM = rng.rotation();
  const Vec3 w_B = rng.vec(2.0), al_B = rng.vec(3.0), a_B = rng.vec(4.0), g_B(0.1, -0.2, -9.8);
  SampleContext c;
  c.R_BS = R_BS;
  c.w_S = R_BS.transpose() * w_B;
  c.alpha_S = R_BS.transpose() * al_B;
  c.a_S = R_BS.transpose() * a_B;
  c.g_S = R_BS.transpose() * g_B;
  c.imu_acc_S = Vec3(1.0, 2.0, 3.0);
  effects::applyMounting(R_SM, &c);
  const Mat3 R_BM = R_BS * R_SM;
  EXPECT_LT((c.R_BS - R_BM).norm(), 1e-14);
  EXPECT_LT((c.w_S - R_BM.transpose() * w_B).norm(), 1e-12);
  EXPECT_LT((c.alpha_S - R_BM.transpose() * al_B).norm(), 1e-12);
  EXPECT_LT((c.a_S - R_BM.transpose() * a_B).norm(), 1e-12);
  EXPECT_LT((c.g_S - R_BM.transpose() * g_B).norm(), 1e-12);
  EXPECT_EQ(c.imu_acc_S, Vec3(1.0, 2.0, 3.0));  // measured in M already
}

TEST(Nonlinear, EvaluatorAppliesCrosstalkToTheOtherEffectsWrench) {
  // reading = (I + E) w_base: the evaluator's two passes against the base model evaluated alone.
  Rng rng;
  const Model base = Model::fromName("paper+rigid_body");
  const Model model = Model::fromName("paper+rigid_body+crosstalk");
  Eigen::VectorXd theta(model.numParams());
  for (int k = 0; k < theta.size(); ++k) theta(k) = rng.uni(-0.03, 0.03);
  theta(model.paramIndex().column("mass")) = 2.0;
  Eigen::VectorXd theta_base(base.numParams());
  for (int k = 0; k < base.numParams(); ++k) {
    theta_base(k) = theta(model.paramIndex().column(base.paramIndex().names()[static_cast<std::size_t>(k)]));
  }
  // E from the names (xt_<row>_<col>, E(t,f) symmetric).
  Mat6 E = Mat6::Zero();
  auto axis = [](const std::string& s) {
    for (int a = 0; a < 6; ++a) {
      if (s == kWrenchAxisNames[a]) return a;
    }
    return -1;
  };
  for (const auto& n : model.paramIndex().names()) {
    if (n.rfind("xt_", 0) != 0) continue;
    const int r = axis(n.substr(3, 2)), c = axis(n.substr(6, 2));
    const double v = theta(model.paramIndex().column(n));
    E(r, c) = v;
    if (r >= 3 && c < 3 && c != r - 3) E(c + 3, r - 3) = v;
  }
  effects::ModelEvaluator eval(model, theta);
  effects::ModelEvaluator eval_base(base, theta_base);
  for (int i = 0; i < 20; ++i) {
    SampleContext ctx = randomContext(rng);
    const Vec6 w_base = eval_base.evaluate(ctx);
    EXPECT_LT((eval.evaluate(ctx) - (w_base + E * w_base)).cwiseAbs().maxCoeff(), 1e-10);
    // The contact is read through the same calibration error and comes back undistorted.
    const Vec6 push = rng.vec(10.0).homogeneous().head<3>().replicate(2, 1);
    ctx.wrench_S = (Mat6::Identity() + E) * (w_base + push);
    Vec6 modelled;
    EXPECT_LT((eval.contact(ctx, &modelled) - push).cwiseAbs().maxCoeff(), 1e-9);
    EXPECT_LT((modelled - (w_base + E * w_base)).cwiseAbs().maxCoeff(), 1e-10);
  }
}

TEST(CrosstalkEffect, EqualsCorrectionMatrixTimesModelledWrench) {
  Rng rng;
  const Model model = Model::fromName("crosstalk");
  EXPECT_EQ(model.numParams(), 31);
  Eigen::VectorXd theta(model.numParams());
  for (int k = 0; k < theta.size(); ++k) theta(k) = rng.uni(-0.02, 0.02);
  // Rebuild E from the parameter names: xt_<row>_<col>; E(t,f) symmetric; E(fz,fz) = E(tz,tz) = 0.
  Mat6 E = Mat6::Zero();
  auto axis = [](const std::string& s) {
    for (int a = 0; a < 6; ++a) {
      if (s == kWrenchAxisNames[a]) return a;
    }
    return -1;
  };
  const auto names = model.paramIndex().names();
  for (std::size_t k = 0; k < names.size(); ++k) {
    const int r = axis(names[k].substr(3, 2));
    const int c = axis(names[k].substr(6, 2));
    ASSERT_GE(r, 0);
    ASSERT_GE(c, 0);
    E(r, c) = theta(static_cast<Eigen::Index>(k));
    if (r >= 3 && c < 3) E(c + 3, r - 3) = theta(static_cast<Eigen::Index>(k));
  }
  EXPECT_EQ(E(2, 2), 0.0);
  EXPECT_EQ(E(5, 5), 0.0);
  EXPECT_LT((E.bottomLeftCorner<3, 3>() - E.bottomLeftCorner<3, 3>().transpose()).cwiseAbs().maxCoeff(), 1e-15);
  for (int trial = 0; trial < 20; ++trial) {
    const SampleContext ctx = randomContext(rng);
    EXPECT_LT((evaluate(model, ctx, theta) - E * ctx.wrench_model_S).cwiseAbs().maxCoeff(), 1e-12);
  }
}

TEST(GenericEffects, HarmonicAndPolyMatchTheirFormulas) {
  Rng rng;
  const Model model = Model::fromName("harmonic(q4,2)+poly(temp,2)+poly(load,1,3)");
  EXPECT_EQ(model.numParams(), 24 + 12 + 6);
  const Eigen::VectorXd theta = Eigen::VectorXd::Random(model.numParams());
  const auto th = [&](const std::string& n) {
    const int c = model.paramIndex().column(n);
    EXPECT_GE(c, 0) << n;
    return c >= 0 ? theta(c) : 0.0;
  };
  const std::vector<std::string> extra_names = {"humidity", "load"};
  for (int trial = 0; trial < 20; ++trial) {
    SampleContext ctx = randomContext(rng);
    const double extra[2] = {0.4, rng.uni(0.0, 6.0)};
    ctx.extra = extra;
    ctx.extra_names = &extra_names;
    const Vec6 got = evaluate(model, ctx, theta);
    for (int a = 0; a < 6; ++a) {
      const std::string ax = kWrenchAxisNames[a];
      double e = 0.0;
      for (int k = 1; k <= 2; ++k) {
        e += th("harm_q4_" + std::to_string(k) + "s_" + ax) * std::sin(k * ctx.q(3)) +
             th("harm_q4_" + std::to_string(k) + "c_" + ax) * std::cos(k * ctx.q(3));
      }
      const double dT = ctx.temp_degC - 25.0;
      e += th("poly_temp_1_" + ax) * dT + th("poly_temp_2_" + ax) * dT * dT;
      e += th("poly_load_1_" + ax) * (extra[1] - 3.0);
      EXPECT_NEAR(got(a), e, 1e-12);
    }
  }
}

TEST(GenericEffects, BadArgumentsGiveClearErrors) {
  EXPECT_THROW(effects::createEffect("harmonic(q4)"), ConfigError);
  EXPECT_THROW(effects::createEffect("harmonic(q4,0)"), ConfigError);
  EXPECT_THROW(effects::createEffect("poly(t,x)"), ConfigError);
  EXPECT_THROW(effects::createEffect("poly(,2)"), ConfigError);
  EXPECT_THROW(effects::createEffect("rigid_body(1)"), ConfigError);
  try {
    effects::createEffect("harmonic(q4,99)");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("harmonic"), std::string::npos);
  }
}

TEST(UserExpression, MatchesTheSameArithmeticWrittenInCpp) {
  Rng rng;
  const std::vector<std::string> extra_names = {"grip", "vacuum"};
  const auto e1 = effects::Expression::parse("grip*qd6 + 2*sin(q4)^2 - wz/3");
  const auto e2 = effects::Expression::parse(" -gz^2 + 2^3^2 - exp(-t/100)*abs(alx) + sqrt(temp) * tanh(vacuum) ");
  const auto e3 = effects::Expression::parse("(ax - ay) * (az + 1.5e-1) / 4 + pi*sign(q1) - cos(q2)*tan(0.3)");
  EXPECT_EQ(e1.text(), "grip*qd6+2*sin(q4)^2-wz/3");
  ASSERT_EQ(e1.signals().size(), 4u);
  EXPECT_EQ(e1.signals()[0].name(), "grip");
  for (int trial = 0; trial < 50; ++trial) {
    SampleContext c = randomContext(rng);
    const double extra[2] = {rng.uni(0.0, 1.0), rng.uni(-2.0, 2.0)};
    c.extra = extra;
    c.extra_names = &extra_names;
    const double s4 = std::sin(c.q(3));
    EXPECT_NEAR(e1.evaluate(c), extra[0] * c.qd(5) + 2.0 * s4 * s4 - c.w_S.z() / 3.0, 1e-12);
    EXPECT_NEAR(e2.evaluate(c),
                -(c.g_S.z() * c.g_S.z()) + 512.0 - std::exp(-c.t_model / 100.0) * std::abs(c.alpha_S.x()) +
                    std::sqrt(c.temp_degC) * std::tanh(extra[1]),
                1e-9);
    const double sgn = c.q(0) > 0.0 ? 1.0 : -1.0;
    EXPECT_NEAR(e3.evaluate(c),
                (c.a_S.x() - c.a_S.y()) * (c.a_S.z() + 0.15) / 4.0 + M_PI * sgn - std::cos(c.q(1)) * std::tan(0.3),
                1e-12);
  }
}

TEST(UserExpression, UndefinedArithmeticIsNaNNotANumberThatLooksValid) {
  SampleContext c;
  const std::vector<std::string> names = {"grip"};
  const double zero[1] = {0.0};
  c.extra = zero;
  c.extra_names = &names;
  EXPECT_TRUE(std::isnan(effects::Expression::parse("1/grip").evaluate(c)));
  EXPECT_TRUE(std::isnan(effects::Expression::parse("log(grip)").evaluate(c)));
  EXPECT_TRUE(std::isnan(effects::Expression::parse("sqrt(grip-1)").evaluate(c)));
  EXPECT_TRUE(std::isnan(effects::Expression::parse("exp(1000)").evaluate(c)));
  EXPECT_TRUE(std::isnan(effects::Expression::parse("humidity*2").evaluate(c)));  // no such column
  EXPECT_EQ(effects::Expression::parse("grip^0").evaluate(c), 1.0);
}

TEST(UserExpression, ErrorsNameTheExpressionAndThePosition) {
  const auto message = [](const std::string& text) {
    try {
      effects::Expression::parse(text);
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  EXPECT_NE(message("grip*").find("at character 6"), std::string::npos) << message("grip*");
  EXPECT_NE(message("sinh(q4)").find("unknown function 'sinh'"), std::string::npos);
  EXPECT_NE(message("(q4+1").find("misses a ')'"), std::string::npos);
  EXPECT_NE(message("q4 q5").find("unexpected 'q'"), std::string::npos);
  EXPECT_NE(message("").find("is empty"), std::string::npos);
  EXPECT_NE(message("q4 # 2").find("unexpected '#'"), std::string::npos);
  EXPECT_NE(message(std::string(200, '(') + "1" + std::string(200, ')')).find("nests too deeply"), std::string::npos);
  std::string long_sum = "1";
  for (int k = 0; k < 100; ++k) long_sum += "+1";
  EXPECT_NE(message(long_sum).find("too long"), std::string::npos);
  std::string deep = "1";
  for (int k = 0; k < 40; ++k) deep = "1+(" + deep + ")";
  EXPECT_NE(message(deep).find("intermediate values"), std::string::npos);
}

TEST(UserEffect, OneCoefficientPerNamedAxisTimesTheExpression) {
  Rng rng;
  const Model model = Model::fromName("paper+expr(fz/tx: grip*qd6)+expr(fz: grip+qd6)");
  EXPECT_EQ(model.name(), "paper+expr(fz/tx: grip*qd6)+expr(fz: grip+qd6)");
  EXPECT_EQ(Model::fromName(model.name()).name(), model.name());  // the canonical name reads back
  const int c_fz = model.paramIndex().column("expr_fz_grip_times_qd6");
  const int c_tx = model.paramIndex().column("expr_tx_grip_times_qd6");
  const int c_sum = model.paramIndex().column("expr_fz_grip_plus_qd6");
  ASSERT_GE(c_fz, 0);
  ASSERT_GE(c_tx, 0);
  ASSERT_GE(c_sum, 0);
  const Model paper = Model::fromName("paper");
  const std::vector<std::string> names = {"grip"};
  for (int trial = 0; trial < 20; ++trial) {
    SampleContext c = randomContext(rng);
    const double extra[1] = {rng.uni(0.0, 1.0)};
    c.extra = extra;
    c.extra_names = &names;
    Eigen::VectorXd theta = Eigen::VectorXd::Zero(model.numParams());
    theta(c_fz) = 1.5;
    theta(c_tx) = -0.2;
    theta(c_sum) = 0.7;
    Vec6 expected = Vec6::Zero();
    expected(2) = 1.5 * extra[0] * c.qd(5) + 0.7 * (extra[0] + c.qd(5));
    expected(3) = -0.2 * extra[0] * c.qd(5);
    EXPECT_LT((evaluate(model, c, theta) - expected).cwiseAbs().maxCoeff(), 1e-12);
  }
  EXPECT_THROW(Model::fromName("paper+expr(fz grip)"), ConfigError);
  EXPECT_THROW(Model::fromName("paper+expr(fw: grip)"), ConfigError);
  EXPECT_THROW(Model::fromName("paper+expr(fz/fz: grip)"), ConfigError);
}

TEST(UserEffect, ALogWithoutTheSignalOrWhereItIsUndefinedIsRefusedByName) {
  const Model model = Model::fromName("paper+expr(fz: log(grip))");
  std::vector<SampleContext> ctx(3);
  EXPECT_NE(model.cannotFit(ctx).find("needs the signal 'grip'"), std::string::npos) << model.cannotFit(ctx);
  const std::vector<std::string> names = {"grip"};
  const double rows[3] = {0.5, 0.2, 0.0};
  for (int i = 0; i < 3; ++i) {
    ctx[static_cast<std::size_t>(i)].t = 0.1 * i;
    ctx[static_cast<std::size_t>(i)].extra = &rows[i];
    ctx[static_cast<std::size_t>(i)].extra_names = &names;
  }
  const std::string why = model.cannotFit(ctx);
  EXPECT_NE(why.find("expr(fz: log(grip)) is not defined at t = 0.2"), std::string::npos) << why;
  EXPECT_NE(why.find("sample 3"), std::string::npos) << why;
  ctx.pop_back();
  EXPECT_EQ(model.cannotFit(ctx), "");
}

TEST(LabEffects, AllComposeAndRegressorsDoNotAllocate) {
  const Model model = Model::fromName(
      "paper+rigid_body+cable+temperature_drift+time_drift+sensor_delay+crosstalk+harmonic(q6,2)+poly(t,3)+"
      "expr(fz/tx: sin(q6)*wz^2 - 3*gz/(1+qd2^2))");
  for (const char* e : {"rigid_body", "cable", "temperature_drift", "time_drift", "sensor_delay", "crosstalk"}) {
    EXPECT_TRUE(model.contains(e)) << e;
  }
  Rng rng;
  const SampleContext ctx = randomContext(rng);
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
