// Compensation of simulated data: with the true parameters (noise-free) the contact wrench is zero;
// a simulated contact push is recovered; non-finite input is rejected.
#include <gtest/gtest.h>

#include <limits>

#include "../identify/paper_cell.hpp"
#include "ftid/common/error.hpp"
#include "ftid/compensate/compensator.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/identify/paper_method.hpp"

namespace ftid::compensate {
namespace {

using test::Table2;

Eigen::VectorXd truthTheta(const effects::Model& model) {
  Eigen::VectorXd theta(model.numParams());
  for (int j = 0; j < model.numParams(); ++j) theta(j) = Table2::value(model.paramIndex().names()[static_cast<std::size_t>(j)]);
  return theta;
}

TEST(Compensator, TrueParametersLeaveZeroOnNoiseFreeData) {
  const samples::ContextSet s = test::contextsOf(test::paperConfig(false, 5));
  const auto model = effects::Model::fromName("paper");
  Compensator comp(model, truthTheta(model), Table2::u(), Table2::v());
  double worst = 0.0, raw = 0.0;
  for (const auto& ctx : s.samples) {
    Wrench contact, modelled;
    ASSERT_EQ(comp.compute(ctx, &contact, &modelled), Status::kOk);
    worst = std::max(worst, contact.cwiseAbs().maxCoeff());
    raw = std::max(raw, ctx.wrench_S.cwiseAbs().maxCoeff());
  }
  EXPECT_GT(raw, 5.0);      // there was something to compensate
  EXPECT_LT(worst, 1e-10);
}

TEST(Compensator, IdentifiedParametersRecoverASimulatedContactPush) {
  sim::CellSimConfig cfg = test::paperConfig(false, 6);
  const samples::ContextSet clean = test::contextsOf(cfg);
  const identify::PaperResult id = identify::identifyPaper(clean.samples);
  const params::ParameterSet set = id.toParameterSet();
  const auto model = effects::Model::fromName(set.model);
  Compensator comp(model, params::thetaFor(model, set), set.tilt_u_rad, set.tilt_v_rad);

  cfg.contact.enabled = true;
  const logio::LogData log = sim::CellSim(cfg).run();
  const samples::ContextSet pushed = samples::buildContexts(log, *cfg.robot);
  const int cfx = log.extraIndex("contact_fx");
  ASSERT_GE(cfx, 0);
  double worst = 0.0, peak = 0.0;
  for (std::size_t i = 0; i < pushed.size(); ++i) {
    Wrench contact;
    ASSERT_EQ(comp.compute(pushed.samples[i], &contact, nullptr), Status::kOk);
    Wrench truth;
    for (int a = 0; a < 6; ++a) truth(a) = log.extra_columns[static_cast<std::size_t>(cfx + a)][i];
    worst = std::max(worst, (contact - truth).cwiseAbs().maxCoeff());
    peak = std::max(peak, truth.cwiseAbs().maxCoeff());
  }
  EXPECT_GT(peak, 1.0);
  EXPECT_LT(worst, 1e-8);
}

TEST(Compensator, RejectsNonFiniteInputAndLeavesOutputs) {
  const auto model = effects::Model::fromName("paper");
  Compensator comp(model, truthTheta(model), 0.0, 0.0);
  effects::SampleContext ctx;
  ctx.wrench_S(2) = std::numeric_limits<double>::quiet_NaN();
  Wrench contact = Wrench::Constant(7.0);
  EXPECT_EQ(comp.compute(ctx, &contact, nullptr), Status::kInvalidInput);
  EXPECT_EQ(contact, Wrench::Constant(7.0));
  ctx.wrench_S.setZero();
  ctx.a_S(0) = std::numeric_limits<double>::infinity();
  EXPECT_EQ(comp.compute(ctx, &contact, nullptr), Status::kInvalidInput);
  ctx.a_S.setZero();
  EXPECT_EQ(comp.compute(ctx, &contact, nullptr), Status::kOk);
}

TEST(Compensator, ConstructionValidatesParameters) {
  const auto model = effects::Model::fromName("paper");
  EXPECT_THROW(Compensator(model, Eigen::VectorXd::Zero(3), 0.0, 0.0), ConfigError);
  Eigen::VectorXd bad = truthTheta(model);
  bad(0) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(Compensator(model, bad, 0.0, 0.0), ConfigError);
}

}  // namespace
}  // namespace ftid::compensate
