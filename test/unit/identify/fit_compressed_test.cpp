// The compressed tilt search of fitModel (FitOptions::compressed_tilt_search, docs/identification.md)
// against two independent references:
//  - the general path (every Gauss-Newton step rebuilds and refactors the stacked 6N x p regressor;
//    the previous implementation, kept behind compressed_tilt_search = false): estimates within a
//    millionth of their standard errors, statistics within 1e-6 relative, on models with and
//    without columns the tilt does not touch;
//  - a brute-force solve in this file: the weighted stacked regressor built sample by sample with
//    g_S = R_BS^T g_B(U, V), solved by SVD, at the fitted tilt (same theta) and on a grid of tilts
//    around it (the fitted tilt has the smallest cost).
// Models that are not affine in gravity (harmonic(gx,1)) fall back to the general path.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "concurrency.hpp"
#include "ftid/common/error.hpp"
#include "ftid/identify/fit.hpp"
#include "ftid/model/frames.hpp"
#include "paper_cell.hpp"

namespace ftid::identify {
namespace {

/// Full rigid-body physics (so paper's model has a systematic error), filtered noise, 125 Hz.
const samples::ContextSet& data() {
  static const samples::ContextSet s = [] {
    sim::CellSimConfig cfg = test::paperConfig(true, 41);
    cfg.full_rigid_body = true;
    cfg.noise.wrench_lowpass_hz = 20.0;
    return test::contextsOf(cfg);
  }();
  return s;
}

FitOptions general() {
  FitOptions o;
  o.compressed_tilt_search = false;
  return o;
}

double relDiff(double a, double b) { return std::abs(a - b) / std::max(std::abs(b), 1e-300); }

/// The two paths stop their Gauss-Newton searches at slightly different points (the steps are the
/// same up to rounding, the stopping tests see rounding-level cost changes; the unweighted pass
/// that sets the axis weights runs only 4 steps). So estimates agree to a millionth of their
/// standard errors, statistics to 1e-6 relative; a wrong compression is off by far more.
void expectSameFit(const FitResult& fast, const FitResult& ref, const std::string& what) {
  SCOPED_TRACE(what);
  ASSERT_EQ(fast.theta.size(), ref.theta.size());
  constexpr double kOfStd = 1e-6;
  constexpr double kRel = 1e-6;
  for (Eigen::Index j = 0; j < ref.theta.size(); ++j) {
    const std::string& name = ref.params[static_cast<std::size_t>(j)].name;
    EXPECT_LT(std::abs(fast.theta(j) - ref.theta(j)), kOfStd * ref.theta_std(j)) << name;
    EXPECT_LT(relDiff(fast.theta_std(j), ref.theta_std(j)), kRel) << name;
  }
  EXPECT_LT(std::abs(fast.tilt_u_rad - ref.tilt_u_rad), kOfStd * ref.tilt_u_std);
  EXPECT_LT(std::abs(fast.tilt_v_rad - ref.tilt_v_rad), kOfStd * ref.tilt_v_std);
  EXPECT_LT(relDiff(fast.tilt_u_std, ref.tilt_u_std), kRel);
  EXPECT_LT(relDiff(fast.tilt_v_std, ref.tilt_v_std), kRel);
  ASSERT_EQ(fast.covariance.rows(), ref.covariance.rows());
  for (Eigen::Index j = 0; j < ref.covariance.rows(); ++j) {
    for (Eigen::Index k = 0; k < ref.covariance.cols(); ++k) {
      const double scale = std::sqrt(ref.covariance(j, j) * ref.covariance(k, k));
      EXPECT_LT(std::abs(fast.covariance(j, k) - ref.covariance(j, k)), kRel * scale) << j << ", " << k;
    }
  }
  EXPECT_LT(relDiff(fast.condition_number, ref.condition_number), kRel);
  EXPECT_LT(relDiff(fast.sigma2, ref.sigma2), kRel);
  for (int a = 0; a < 6; ++a) {
    EXPECT_LT(relDiff(fast.axis_weights(a), ref.axis_weights(a)), kRel) << a;
    EXPECT_LT(relDiff(fast.residual_rms(a), ref.residual_rms(a)), kRel) << a;
    EXPECT_LT((fast.residual.row(a) - ref.residual.row(a)).cwiseAbs().maxCoeff(), kRel * ref.residual_rms(a)) << a;
  }
  ASSERT_EQ(fast.derived.size(), ref.derived.size());
  for (std::size_t k = 0; k < ref.derived.size(); ++k) {
    EXPECT_LT(std::abs(fast.derived[k].value - ref.derived[k].value), kOfStd * ref.derived[k].std) << ref.derived[k].name;
    EXPECT_LT(relDiff(fast.derived[k].std, ref.derived[k].std), kRel) << ref.derived[k].name;
  }
  EXPECT_EQ(fast.n_samples, ref.n_samples);
  EXPECT_TRUE(fast.tilt_estimated);
}

class CompressedTilt : public ::testing::TestWithParam<const char*> {};

TEST_P(CompressedTilt, AgreesWithTheGeneralPath) {
  const Model model = Model::fromName(GetParam());
  const FitResult fast = fitModel(model, data().samples);
  const FitResult ref = fitModel(model, data().samples, general());
  expectSameFit(fast, ref, GetParam());
  // A subset (cross-validation's call) as well.
  std::vector<int> idx;
  for (int i = 200; i < 900; ++i) idx.push_back(i);
  expectSameFit(fitModel(model, data().samples, idx), fitModel(model, data().samples, idx, general()),
                std::string(GetParam()) + " on a subset");
}

INSTANTIATE_TEST_SUITE_P(Models, CompressedTilt,
                         ::testing::Values("paper", "paper+rigid_body", "paper+rigid_body+cable",
                                           "paper+harmonic(q6,1)", "paper+poly(gz,1)"));

TEST(CompressedTilt, UnweightedFromAGivenStartAgreesWithTheGeneralPath) {
  FitOptions o;
  o.axis_weights = false;
  o.tilt_u_rad = 0.01;
  o.tilt_v_rad = -0.02;
  FitOptions g = o;
  g.compressed_tilt_search = false;
  const Model model = Model::fromName("paper+rigid_body");
  expectSameFit(fitModel(model, data().samples, o), fitModel(model, data().samples, g), "unweighted, given start");
}

/// Weighted SSE and theta of the stacked problem at tilt (u, v), built here sample by sample.
struct Direct {
  double sse = 0.0;
  Eigen::VectorXd theta;
};

Direct directSolve(const Model& model, const std::vector<SampleContext>& samples, double u, double v,
                   const Vec6& w) {
  const Eigen::Index n = static_cast<Eigen::Index>(samples.size());
  const int p = model.numParams();
  Eigen::MatrixXd A(6 * n, p);
  Eigen::VectorXd y(6 * n);
  Eigen::Matrix<double, 6, Eigen::Dynamic> Y(6, p);
  const Vec3 g_B = model::gravityInBase(u, v);
  for (Eigen::Index i = 0; i < n; ++i) {
    SampleContext c = samples[static_cast<std::size_t>(i)];
    c.g_S = c.R_BS.transpose() * g_B;
    model.computeRegressor(c, Y);
    A.middleRows(6 * i, 6) = w.asDiagonal() * Y;
    y.segment<6>(6 * i) = w.cwiseProduct(c.wrench_S);
  }
  Direct d;
  d.theta = A.jacobiSvd(Eigen::ComputeThinU | Eigen::ComputeThinV).solve(y);
  d.sse = (y - A * d.theta).squaredNorm();
  return d;
}

TEST(CompressedTilt, MinimisesTheDirectlyBuiltCost) {
  const Model model = Model::fromName("paper+rigid_body");
  const FitResult fit = fitModel(model, data().samples);
  const Direct at = directSolve(model, data().samples, fit.tilt_u_rad, fit.tilt_v_rad, fit.axis_weights);
  EXPECT_LT((at.theta - fit.theta).cwiseAbs().maxCoeff(), 1e-9 * fit.theta.cwiseAbs().maxCoeff());
  // sigma2 is the weighted SSE over the degrees of freedom.
  const int dof = 6 * fit.n_samples - (model.numParams() + 2);
  EXPECT_NEAR(fit.sigma2, at.sse / dof, 1e-9 * fit.sigma2);
  // No tilt on a grid around the fit (steps of a few standard errors and of 1 mrad) does better.
  for (double step : {3.0 * std::max(fit.tilt_u_std, fit.tilt_v_std), 1e-3}) {
    for (int du = -1; du <= 1; ++du) {
      for (int dv = -1; dv <= 1; ++dv) {
        if (du == 0 && dv == 0) continue;
        const Direct d = directSolve(model, data().samples, fit.tilt_u_rad + du * step, fit.tilt_v_rad + dv * step,
                                     fit.axis_weights);
        EXPECT_GT(d.sse, at.sse) << "du " << du * step << " dv " << dv * step;
      }
    }
  }
}

TEST(CompressedTilt, NotAffineInGravityFallsBackToTheGeneralPath) {
  // sin(gx) is not affine in g_S: the compression would be wrong, so the general path runs.
  const Model model = Model::fromName("paper+harmonic(gx,1)");
  const FitResult fast = fitModel(model, data().samples);
  const FitResult ref = fitModel(model, data().samples, general());
  EXPECT_EQ(fast.theta, ref.theta);
  EXPECT_EQ(fast.tilt_u_rad, ref.tilt_u_rad);
  EXPECT_EQ(fast.covariance, ref.covariance);
}

/// An offset on fx inside one short time window (t_lo < t < t_hi), zero elsewhere; registered as
/// effect `name` with the parameter `name` + "_fx".
class TestWindowOffset final : public effects::Effect {
 public:
  TestWindowOffset(std::string name, double t_lo, double t_hi) : name_(std::move(name)), t_lo_(t_lo), t_hi_(t_hi) {}
  static void add(const std::string& name, double t_lo, double t_hi) {
    effects::registerEffect(name, "test only", [name, t_lo, t_hi](const std::string&) {
      return std::make_unique<TestWindowOffset>(name, t_lo, t_hi);
    });
  }
  std::string name() const override { return name_; }
  std::string description() const override { return "test only"; }
  std::vector<effects::ParamInfo> params() const override { return {{name_ + "_fx", "N", "window offset"}}; }
  void bind(const effects::ParamIndex& index) override { col_ = effects::requireColumn(index, name_ + "_fx", name()); }
  void addRegressor(const SampleContext& ctx,
                    Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>> Y) const noexcept override {
    if (ctx.t > t_lo_ && ctx.t < t_hi_) Y(0, col_) += 1.0;
  }
  std::unique_ptr<effects::Effect> clone() const override { return std::make_unique<TestWindowOffset>(*this); }

 private:
  std::string name_;
  double t_lo_;
  double t_hi_;
  int col_ = 0;
};

TEST(CompressedTilt, FindsAColumnTheProbeSamplesMiss) {
  // 3.97 s < t < 4.08 s: samples 497-510 at 125 Hz, none of them among the compression's probe
  // samples (every 19th).
  TestWindowOffset::add("test_window_offset", 3.97, 4.08);
  ASSERT_EQ(data().size(), 1251u);  // the probe stride (19) and the window above assume this
  const Model model = Model::fromName("paper+test_window_offset");
  expectSameFit(fitModel(model, data().samples), fitModel(model, data().samples, general()),
                "window offset");
}

TEST(CompressedTilt, FindsAGravityColumnTheProbeSamplesMiss) {
  // On the probe samples (every 19th) the sensor's axes are the base's, permuted: R_BS has zeros,
  // so entries of the gravity columns E_k (s R_BS(k, j) for the mass, its cross products for the
  // first moments) are zero there and non-zero elsewhere; the pass must find them.
  std::vector<SampleContext> s = data().samples;
  ASSERT_EQ(s.size(), 1251u);  // the probe stride (19) assumes this
  Mat3 perm;
  perm << 0, 1, 0, 0, 0, 1, 1, 0, 0;
  for (std::size_t i = 0; i < s.size(); i += 19) s[i].R_BS = perm;
  for (const char* name : {"paper", "paper+poly(gz,1)"}) {
    const Model model = Model::fromName(name);
    expectSameFit(fitModel(model, s), fitModel(model, s, general()), std::string("permuted probes, ") + name);
  }
}

/// The same cell at 500 Hz (5,001 samples): from 4,096 samples on, the compression's passes run in
/// two halves (the second on a thread of its own where there is a second core).
const samples::ContextSet& denseData() {
  static const samples::ContextSet s = [] {
    sim::CellSimConfig cfg = test::paperConfig(true, 43);
    cfg.full_rigid_body = true;
    cfg.noise.wrench_lowpass_hz = 20.0;
    cfg.rate_hz = 500.0;
    return test::contextsOf(cfg);
  }();
  return s;
}

TEST(CompressedTilt, TwoHalvesAgreeWithTheGeneralPath) {
  ASSERT_EQ(denseData().size(), 5001u);
  const Model model = Model::fromName("paper+rigid_body");
  const FitResult fast = fitModel(model, denseData().samples);
  expectSameFit(fast, fitModel(model, denseData().samples, general()), "5,001 samples");
  // The split depends on the number of samples alone: a fit of other data in between (the
  // scratch is reused) and a fit with both halves on this thread (internal::serialOnly, as on a
  // one-CPU machine) are bit for bit the same.
  (void)fitModel(model, data().samples);
  struct SerialOnly {
    SerialOnly() { internal::serialOnly() = true; }
    ~SerialOnly() { internal::serialOnly() = false; }
  };
  FitResult serial;
  {
    const SerialOnly one_thread;
    serial = fitModel(model, denseData().samples);
  }
  const FitResult again = fitModel(model, denseData().samples);
  for (const FitResult* other : std::array<const FitResult*, 2>{&serial, &again}) {
    EXPECT_EQ(other->theta, fast.theta);
    EXPECT_EQ(other->covariance, fast.covariance);
    EXPECT_EQ(other->residual, fast.residual);
    EXPECT_EQ(other->axis_weights, fast.axis_weights);
  }
}

TEST(CompressedTilt, TwoHalvesFindAColumnOnlyTheSecondHalfExcitesAndNameItsFirstNonFiniteSample) {
  // An offset on fx only in 8.0 s < t < 8.1 s (samples 4001-4049 of 5,001, the second half, none a
  // probe sample: every 78th) must be found by the second half's pass.
  TestWindowOffset::add("test_late_offset", 8.0, 8.1);
  ASSERT_EQ(denseData().size(), 5001u);
  const Model model = Model::fromName("paper+test_late_offset");
  expectSameFit(fitModel(model, denseData().samples), fitModel(model, denseData().samples, general()),
                "late offset");
  // Non-finite values in both halves: the first is named; in the second half alone: that one.
  for (const std::pair<int, int>& bad : {std::pair<int, int>{1777, 4444}, {4444, -1}}) {
    std::vector<SampleContext> c = denseData().samples;
    c[static_cast<std::size_t>(bad.first)].imu_w_S(1) = std::nan("");
    if (bad.second >= 0) c[static_cast<std::size_t>(bad.second)].alpha_S(0) = -std::numeric_limits<double>::infinity();
    try {
      (void)fitModel(Model::fromName("paper"), c);
      ADD_FAILURE() << "no DataError";
    } catch (const DataError& e) {
      EXPECT_NE(std::string(e.what()).find("sample " + std::to_string(bad.first) + " ("), std::string::npos) << e.what();
    }
  }
}

TEST(CompressedTilt, StartsAtThePapersStaticForceStage) {
  // With no Gauss-Newton step the fit reports its start: the compressed search solves the paper's
  // static force stage on its own compressed data; initialTilt() runs the paper's method itself.
  FitOptions o;
  o.axis_weights = false;
  o.max_tilt_iterations = 0;
  std::vector<int> all, part;
  for (int i = 0; i < static_cast<int>(data().size()); ++i) all.push_back(i);
  for (int i = 300; i < 700; ++i) part.push_back(i);
  for (const char* name : {"paper", "paper+rigid_body"}) {
    for (const std::vector<int>* idx : {&all, &part}) {
      SCOPED_TRACE(std::string(name) + (idx == &all ? "" : ", subset"));
      double u = 0.0, v = 0.0;
      ASSERT_TRUE(initialTilt(data().samples, *idx, &u, &v));
      const FitResult fit = fitModel(Model::fromName(name), data().samples, *idx, o);
      EXPECT_NEAR(fit.tilt_u_rad, u, 1e-12);
      EXPECT_NEAR(fit.tilt_v_rad, v, 1e-12);
      EXPECT_GT(std::abs(u) + std::abs(v), 1e-3);  // the simulated cell is tilted: not the level fallback
    }
  }
}

TEST(CompressedTilt, IllConditionedDataAgreeWithTheGeneralPath) {
  // A short window (0.4 s) excites the parameters poorly: the compression factors by Householder
  // QR instead of the Gram matrix (condition number above 1e3) and still agrees.
  std::vector<int> idx;
  for (int i = 600; i < 650; ++i) idx.push_back(i);
  const Model model = Model::fromName("paper");
  const FitResult ref = fitModel(model, data().samples, idx, general());
  ASSERT_GT(ref.condition_number, 1e3);
  expectSameFit(fitModel(model, data().samples, idx), ref, "short window");
}

TEST(CompressedTilt, UndeterminedParametersGiveTheSameError) {
  // Rest poses cannot determine the inertia: both paths name the same parameters.
  sim::CellSimConfig cfg = test::paperConfig(true, 42);
  test::useRestPoses(cfg, 12, 5);
  const samples::ContextSet s = test::contextsOf(cfg);
  const Model model = Model::fromName("paper+rigid_body");
  std::string fast_msg, ref_msg;
  try {
    (void)fitModel(model, s.samples);
  } catch (const IdentificationError& e) {
    fast_msg = e.what();
  }
  try {
    (void)fitModel(model, s.samples, general());
  } catch (const IdentificationError& e) {
    ref_msg = e.what();
  }
  EXPECT_NE(ref_msg.find("i_s_"), std::string::npos) << ref_msg;
  EXPECT_EQ(fast_msg, ref_msg);
}

}  // namespace
}  // namespace ftid::identify
