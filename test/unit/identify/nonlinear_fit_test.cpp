// The fitting core's nonlinear step on treated data (ftid/identify/nonlinear_fit.hpp), against
// independent formulations:
//  - the stacked design against a row-by-row construction in this file (regressor from
//    Model::computeRegressor with g_S = R_BS^T g_B(U, V), AR(1) filter and row weights written
//    out per (sample, axis));
//  - the analytic tilt columns and the delay column (-d/dt of the prediction) against central
//    differences of the prediction in U, V and the delay;
//  - the fit against the simulator's truth (base tilt, sensor mounting rotation, delay; its own
//    Newton-Euler physics) and against fitModel's variable projection (QR, numeric Jacobian);
//  - held-out and zero-weighted samples: corrupting them does not move the fit.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <vector>

#include "ftid/effects/nonlinear.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/identify/nonlinear_fit.hpp"
#include "ftid/model/frames.hpp"
#include "paper_cell.hpp"

namespace ftid::identify {
namespace {

using effects::Model;

constexpr double kDeg = 3.141592653589793 / 180.0;
constexpr double kDelay_s = 0.012;

Mat3 trueMounting() {
  return (Eigen::AngleAxisd(2.0 * kDeg, Vec3::UnitZ()) * Eigen::AngleAxisd(-1.0 * kDeg, Vec3::UnitY()) *
          Eigen::AngleAxisd(1.5 * kDeg, Vec3::UnitX()))
      .toRotationMatrix();
}

/// The paper cell (Table 2 tilt) with the sensor rotated against the configured frame and a delay;
/// noise-free, the paper's physics (so `paper+mounting+sensor_delay` is the exact model).
const std::vector<SampleContext>& cellData() {
  static const std::vector<SampleContext> s = [] {
    sim::CellSimConfig cfg = test::paperConfig(false, 7);
    cfg.R_FS = trueMounting();
    cfg.sensor_delay.enabled = true;
    cfg.sensor_delay.tau_s = kDelay_s;
    return test::contextsOf(cfg).samples;  // configured: S = F
  }();
  return s;
}

Eigen::VectorXd someTheta(const Model& model) {
  Eigen::VectorXd theta(model.numParams());
  for (int k = 0; k < theta.size(); ++k) theta(k) = 0.01 * std::sin(1.7 * k + 0.3);
  theta(model.paramIndex().column("mass")) = 2.5;
  return theta;
}

TEST(NonlinearFitCore, DesignIsTheWeightedFilteredRowWeightedRegressor) {
  const Model model = Model::fromName("paper+rigid_body");
  std::vector<SampleContext> ctx(cellData().begin(), cellData().begin() + 200);
  DataTreatment tr;
  tr.axis_weights << 2.0, 3.0, 4.0, 50.0, 60.0, 70.0;
  tr.ar1 << 0.5, 0.0, -0.3, 0.8, 0.0, 0.2;
  tr.filter_start = {0, 70, 150};
  std::vector<char> excluded(ctx.size(), 0);
  excluded[10] = excluded[70] = excluded[149] = excluded[151] = 1;
  tr.row_weights = exclusionWeights(excluded, tr.ar1, tr.filter_start, static_cast<int>(ctx.size()));
  // The excluded rows and, on a filtered axis, the next row of the same run are out.
  for (int a = 0; a < 6; ++a) {
    const bool filtered = tr.ar1(a) != 0.0;
    EXPECT_EQ(tr.row_weights(a, 10), 0.0);
    EXPECT_EQ(tr.row_weights(a, 11), filtered ? 0.0 : 1.0);
    EXPECT_EQ(tr.row_weights(a, 70), 0.0);
    EXPECT_EQ(tr.row_weights(a, 71), filtered ? 0.0 : 1.0);
    EXPECT_EQ(tr.row_weights(a, 149), 0.0);
    EXPECT_EQ(tr.row_weights(a, 150), 1.0);  // the next run starts its own filter
    EXPECT_EQ(tr.row_weights(a, 152), filtered ? 0.0 : 1.0);
    EXPECT_EQ(tr.row_weights(a, 12), 1.0);
  }
  EXPECT_DOUBLE_EQ(tr.row_weights.sum(), 6 * 200 - 6 * 4 - 4 * 3);  // 4 filtered axes, 3 next rows
  const NonlinearFit core(ctx, tr);
  Linearization lin;
  lin.u = 0.02;
  lin.v = -0.01;
  const NonlinearFit::Design X = core.design(model, lin);
  const int p = model.numParams();
  ASSERT_EQ(X.rows(), 6 * 200);
  ASSERT_EQ(X.cols(), p + 1);
  // Row by row: raw(i) = w_a [Y_a(ctx_i with g_S from the tilt), wrench_a].
  const Vec3 g_B = model::gravityInBase(lin.u, lin.v);
  auto raw = [&](int i, int a) {
    SampleContext c = ctx[static_cast<std::size_t>(i)];
    c.g_S = c.R_BS.transpose() * g_B;
    c.wrench_model_S.setZero();
    Eigen::Matrix<double, 6, Eigen::Dynamic> Y(6, p);
    model.computeRegressor(c, Y);
    Eigen::RowVectorXd row(p + 1);
    row.head(p) = Y.row(a);
    row(p) = c.wrench_S(a);
    return Eigen::RowVectorXd(tr.axis_weights(a) * row);
  };
  double worst = 0.0;
  std::vector<bool> seen(static_cast<std::size_t>(6 * 200), false);
  for (int i = 0; i < 200; ++i) {
    const bool first = i == 0 || i == 70 || i == 150;
    for (int a = 0; a < 6; ++a) {
      const double phi = tr.ar1(a);
      const Eigen::RowVectorXd expected =
          tr.row_weights(a, i) * (first ? Eigen::RowVectorXd(std::sqrt(1.0 - phi * phi) * raw(i, a))
                                        : Eigen::RowVectorXd(raw(i, a) - phi * raw(i - 1, a)));
      const int r = core.rowOf(i, a);
      seen[static_cast<std::size_t>(r)] = true;
      worst = std::max(worst, (X.row(r) - expected).cwiseAbs().maxCoeff() / std::max(1.0, expected.cwiseAbs().maxCoeff()));
    }
  }
  EXPECT_LT(worst, 1e-12);
  for (bool s : seen) EXPECT_TRUE(s);  // rowOf is a permutation
  // Each (run, axis) is one contiguous time series.
  EXPECT_EQ(core.rowOf(71, 2), core.rowOf(70, 2) + 1);
  EXPECT_EQ(core.rowOf(70, 0), 6 * 70);
}

TEST(NonlinearFitCore, JacobianColumnsAreTheDerivativesOfThePrediction) {
  const Model model = Model::fromName("paper+rigid_body+mounting+sensor_delay");
  const NonlinearFit core(cellData(), DataTreatment{});
  const Eigen::VectorXd theta = someTheta(model);
  Linearization lin;
  lin.u = 0.03;
  lin.v = -0.02;
  lin.mount = Vec3(0.01, -0.02, 0.015);
  lin.delay = 0.004;
  core.tiltColumns(model, lin, theta);
  core.mountColumns(model, lin, theta);
  core.delayColumn(model, lin, theta);
  auto centralDifference = [&](auto shift, double h) {
    Linearization lp = lin;
    Linearization lm = lin;
    shift(lp, h);
    shift(lm, -h);
    return Mat6X((core.predict(model, lp, theta, false) - core.predict(model, lm, theta, false)) / (2.0 * h));
  };
  auto relErr = [](const Mat6X& a, const Mat6X& b) { return (a - b).cwiseAbs().maxCoeff() / b.cwiseAbs().maxCoeff(); };
  EXPECT_LT(relErr(lin.j_u, centralDifference([](Linearization& l, double h) { l.u += h; }, 1e-5)), 1e-7);
  EXPECT_LT(relErr(lin.j_v, centralDifference([](Linearization& l, double h) { l.v += h; }, 1e-5)), 1e-7);
  for (int k = 0; k < 3; ++k) {
    EXPECT_LT(relErr(lin.j_m[static_cast<std::size_t>(k)],
                     centralDifference([k](Linearization& l, double h) { l.mount(k) += h; }, 1e-4)),
              1e-6)
        << k;
  }
  // The delay shift interpolates the kinematics linearly between samples, the column is a central
  // difference along time: equal up to the discretisation (samples 8 ms apart), away from the ends.
  const Mat6X fd = centralDifference([](Linearization& l, double h) { l.delay += h; }, 2e-3);
  const Eigen::Index n = fd.cols();
  EXPECT_LT(relErr(lin.j_d.middleCols(5, n - 10), fd.middleCols(5, n - 10)), 2e-2);
}

struct Recovered {
  double u, v, delay;
  Vec3 mount;
  Eigen::VectorXd theta;
};

Recovered runFit(const Model& model, const NonlinearFit& core) {
  Linearization lin = core.fit(model, core.initial(model));
  const Eigen::VectorXd x = core.solveFit(core.design(model, lin));
  const int p = model.numParams();
  Recovered r;
  r.u = lin.u + x(p);
  r.v = lin.v + x(p + 1);
  r.mount = lin.mount + x.segment<3>(lin.mountColumn(p));
  r.delay = lin.delay + x(lin.delayColumn(p));
  r.theta = x.head(p);
  return r;
}

TEST(NonlinearFitCore, FitFindsTiltMountingAndDelayOfTheSimulatedCell) {
  const Model model = Model::fromName("paper+mounting+sensor_delay");
  const NonlinearFit core(cellData(), DataTreatment{});
  const Recovered r = runFit(model, core);
  // The simulator's truth: Table 2 tilt, R_SM = Rz(2 deg) Ry(-1 deg) Rx(1.5 deg), 12 ms (the
  // linear interpolation of the delayed kinematics at 125 Hz leaves errors below 1e-5).
  EXPECT_NEAR(r.u, test::Table2::u(), 2e-5);
  EXPECT_NEAR(r.v, test::Table2::v(), 2e-5);
  EXPECT_NEAR(r.mount(0), 1.5 * kDeg, 2e-5);
  EXPECT_NEAR(r.mount(1), -1.0 * kDeg, 2e-5);
  EXPECT_NEAR(r.mount(2), 2.0 * kDeg, 2e-5);
  EXPECT_NEAR(r.delay, kDelay_s, 2e-5);
  EXPECT_NEAR(r.theta(model.paramIndex().column("mass")), test::Table2::mass(), 1e-4 * test::Table2::mass());
  // fitModel's variable projection (QR solves, numeric Jacobian of the projected residual) with
  // its axis weights (1 / residual RMS): the same weighted objective up to the samples at the
  // ends that the delay moves out of the log (fitModel drops those of its whole delay window).
  const FitResult ref = fitModel(model, cellData());
  DataTreatment same;
  same.axis_weights = ref.axis_weights;
  const Recovered w = runFit(model, NonlinearFit(cellData(), same));
  EXPECT_NEAR(w.u, ref.tilt_u_rad, 1e-7);
  EXPECT_NEAR(w.v, ref.tilt_v_rad, 1e-7);
  EXPECT_LT((w.mount - ref.mount_rpy_rad).cwiseAbs().maxCoeff(), 1e-7);
  EXPECT_NEAR(w.delay, ref.delay_s, 1e-7);
  EXPECT_LT((w.theta - ref.theta).cwiseAbs().maxCoeff(), 1e-6 * ref.theta.cwiseAbs().maxCoeff());
}

TEST(NonlinearFitCore, HeldOutAndZeroWeightedSamplesHaveNoSayInTheFit) {
  const Model model = Model::fromName("paper+mounting+sensor_delay");
  const std::vector<SampleContext>& clean = cellData();
  const int n = static_cast<int>(clean.size());
  const int n_fit = (3 * n) / 4;
  DataTreatment tr;
  tr.ar1 << 0.6, 0.0, 0.3, -0.4, 0.5, 0.0;
  tr.filter_start = {0, n_fit / 2, n_fit};
  tr.n_fit = n_fit;
  tr.segment_start = {0, n_fit};  // the held-out part is a log of its own
  std::vector<char> excluded(clean.size(), 0);
  for (int i : {100, 101, 250, n_fit / 2 - 1, n_fit - 1}) excluded[static_cast<std::size_t>(i)] = 1;
  tr.row_weights = exclusionWeights(excluded, tr.ar1, tr.filter_start, n);
  std::vector<SampleContext> corrupted = clean;
  for (int i = 0; i < n; ++i) {
    if (excluded[static_cast<std::size_t>(i)] || i >= n_fit) corrupted[static_cast<std::size_t>(i)].wrench_S += Wrench::Constant(40.0);
  }
  const Recovered a = runFit(model, NonlinearFit(clean, tr));
  const Recovered b = runFit(model, NonlinearFit(corrupted, tr));
  EXPECT_NEAR(a.u, b.u, 1e-10);
  EXPECT_NEAR(a.v, b.v, 1e-10);
  EXPECT_LT((a.mount - b.mount).cwiseAbs().maxCoeff(), 1e-10);
  EXPECT_NEAR(a.delay, b.delay, 1e-10);
  EXPECT_LT((a.theta - b.theta).cwiseAbs().maxCoeff(), 1e-8);
  // And the treated fit still finds the truth (its first log only).
  EXPECT_NEAR(a.delay, kDelay_s, 2e-5);
  EXPECT_NEAR(a.u, test::Table2::u(), 2e-5);
}

TEST(NonlinearFitCore, TreatmentThatDoesNotFitTheDataIsRefused) {
  const std::vector<SampleContext> ctx(cellData().begin(), cellData().begin() + 50);
  DataTreatment tr;
  tr.filter_start = {0, 20};
  tr.n_fit = 30;  // not a run boundary
  EXPECT_THROW(NonlinearFit(ctx, tr), std::invalid_argument);
  tr.n_fit = 20;
  EXPECT_NO_THROW(NonlinearFit(ctx, tr));
  tr.filter_start = {5, 20};
  EXPECT_THROW(NonlinearFit(ctx, tr), std::invalid_argument);
  tr.filter_start = {0, 20, 20};
  EXPECT_THROW(NonlinearFit(ctx, tr), std::invalid_argument);
  tr.filter_start = {0};
  tr.n_fit = -1;
  tr.row_weights = Mat6X::Ones(6, 49);
  EXPECT_THROW(NonlinearFit(ctx, tr), std::invalid_argument);
}

}  // namespace
}  // namespace ftid::identify
