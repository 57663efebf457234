// The model laboratory: held-out validation, diagnostics, candidate ranking, forward selection
// (include/ftid/lab/analyze.hpp, docs/analyze.md).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <optional>
#include <tuple>
#include <utility>

#include "change_point_scan.hpp"
#include "lab_internal.hpp"
#include "extra_signals.hpp"
#include "imu_check.hpp"
#include "dynamics_check.hpp"
#include "spectrum_report.hpp"
#include "ftid/effects/nonlinear.hpp"
#include "ftid/common/error.hpp"
#include "ftid/effects/cable.hpp"
#include "ftid/effects/model.hpp"
#include "ftid/effects/signal_source.hpp"
#include "ftid/identify/noise.hpp"
#include "ftid/identify/robust_data.hpp"
#include "ftid/lab/analyze.hpp"

namespace ftid::lab {

namespace detail {

using effects::Model;

ModelReport makeReport(const Engine& eng, const Model& model, const Linearization& lin, const Solution& sol) {
  ModelReport r;
  r.model = model.name();
  const auto params = model.params();
  const int p = model.numParams();
  const auto stdOf = [&](int k) { return std::sqrt(std::max(0.0, sol.covariance(k, k))); };
  for (int k = 0; k < p; ++k) {
    r.params.push_back({params[static_cast<std::size_t>(k)].name, params[static_cast<std::size_t>(k)].unit,
                        sol.theta(k), stdOf(k)});
  }
  r.tilt_estimated = lin.tilt_columns;
  // Angles in their principal range (-pi, pi].
  r.tilt_u_rad = wrapAngle(lin.u + (lin.tilt_columns ? sol.theta(p) : 0.0));
  r.tilt_v_rad = wrapAngle(lin.v + (lin.tilt_columns ? sol.theta(p + 1) : 0.0));
  if (lin.tilt_columns) {
    r.params.push_back({"tilt_u", "rad", r.tilt_u_rad, stdOf(p)});
    r.params.push_back({"tilt_v", "rad", r.tilt_v_rad, stdOf(p + 1)});
  }
  if (lin.mount_columns) {
    const int c = lin.mountColumn(p);
    for (int k = 0; k < 3; ++k) {
      r.params.push_back({effects::kMountParamNames[k], "rad", wrapAngle(lin.mount(k) + sol.theta(c + k)), stdOf(c + k)});
    }
  }
  if (lin.delay_column) {
    const int c = lin.delayColumn(p);
    r.params.push_back({effects::kDelayParamName, "s", lin.delay + sol.theta(c), stdOf(c)});
  }
  const auto& idx = model.paramIndex();
  const int cm = idx.column("mass");
  if (cm >= 0 && sol.theta(cm) > 0.0) {
    const double m = sol.theta(cm);
    r.params.push_back({"weight", "N", m * kStandardGravity, stdOf(cm) * kStandardGravity});
    const char* axes[3] = {"x", "y", "z"};
    for (int a = 0; a < 3; ++a) {
      const int cc = idx.column(std::string("mass_com_") + axes[a]);
      if (cc < 0) continue;
      // com = mc / m: gradient (-mc/m^2, 1/m).
      const double mc = sol.theta(cc);
      const double g0 = -mc / (m * m), g1 = 1.0 / m;
      const double var = g0 * g0 * sol.covariance(cm, cm) + 2.0 * g0 * g1 * sol.covariance(cm, cc) +
                         g1 * g1 * sol.covariance(cc, cc);
      r.params.push_back({std::string("com_") + axes[a], "m", mc / m, std::sqrt(std::max(0.0, var))});
    }
    if (model.contains("rigid_body")) {
      std::vector<int> cols = {cm, idx.column("mass_com_x"), idx.column("mass_com_y"), idx.column("mass_com_z")};
      for (const char* n : effects::kInertiaParamNames) cols.push_back(idx.column(n));
      Eigen::Matrix<double, 10, 1> pv;
      Eigen::Matrix<double, 10, 10> cv;
      for (int i = 0; i < 10; ++i) {
        pv(i) = sol.theta(cols[static_cast<std::size_t>(i)]);
        for (int j = 0; j < 10; ++j) cv(i, j) = sol.covariance(cols[static_cast<std::size_t>(i)], cols[static_cast<std::size_t>(j)]);
      }
      r.inertia = effects::inertiaAboutCom(pv, cv);
      const char* in[6] = {"i_c_xx", "i_c_yy", "i_c_zz", "i_c_xy", "i_c_xz", "i_c_yz"};
      for (int k = 0; k < 6; ++k) r.params.push_back({in[k], "kg*m^2", r.inertia->value(k), r.inertia->std(k)});
    }
  }
  const int ck = idx.column(effects::kCableStiffnessParam);
  if (ck >= 0 && std::abs(sol.theta(ck)) > 0.0) {
    const double k = sol.theta(ck);
    const char* axes[3] = {"x", "y", "z"};
    for (int a = 0; a < 3; ++a) {
      const int cu = idx.column(effects::kCableAttachParams[a]);
      const double u = sol.theta(cu);
      const double g0 = -u / (k * k), g1 = 1.0 / k;
      const double var = g0 * g0 * sol.covariance(ck, ck) + 2.0 * g0 * g1 * sol.covariance(ck, cu) +
                         g1 * g1 * sol.covariance(cu, cu);
      r.params.push_back({std::string("cable_attach_") + axes[a], "m", u / k, std::sqrt(std::max(0.0, var))});
    }
  }
  // RMS per axis.
  const auto& tests = eng.testSamples();
  for (int i : tests) r.raw_rms += eng.data().ctx[static_cast<std::size_t>(i)].wrench_S.cwiseAbs2();
  r.raw_rms = (r.raw_rms / std::max<double>(1.0, static_cast<double>(tests.size()))).cwiseSqrt();
  r.residual_rms = (sol.sse_heldout_axis / std::max(1, sol.n_heldout)).cwiseSqrt();
  r.fit_residual_rms = (sol.sse_fit_axis / std::max(1, eng.data().n_fit)).cwiseSqrt();
  r.condition_number = sol.condition_number;
  return r;
}

double totalRatio(const Vec6& rms, const Vec6& noise) {
  return std::sqrt(rms.cwiseQuotient(noise).cwiseAbs2().mean());
}

}  // namespace detail

namespace {

using detail::Dataset;
using detail::Engine;
using detail::Fitted;
using detail::Linearization;
using detail::Mat6X;
using detail::Solution;
using detail::fmt;
using detail::say;
using effects::Model;



/// Signals the residual is correlated against: name and per-sample value.
struct SignalSeries {
  std::string name;
  std::vector<double> values;
};

std::vector<SignalSeries> diagnosticSignals(const Engine& eng, const Linearization& lin) {
  const auto& tests = eng.testSamples();
  const auto& ctx = eng.data().ctx;
  std::vector<std::string> names = {"t", "q1", "q2", "q3", "q4", "q5", "q6", "qd1", "qd2", "qd3", "qd4", "qd5", "qd6",
                                    "wx", "wy", "wz", "alx", "aly", "alz", "ax", "ay", "az"};
  if (ctx.front().has_temp) names.push_back("temp");
  for (const auto& n : detail::extraSignals(ctx).names) names.push_back(n);  // extra columns (extra_signals.hpp)
  std::vector<SignalSeries> out;
  for (const auto& n : names) {
    const auto src = effects::SignalSource::parse(n);
    SignalSeries s{n, {}};
    for (int i : tests) s.values.push_back(src.read(ctx[static_cast<std::size_t>(i)]));
    out.push_back(std::move(s));
  }
  const char* sq[3] = {"wx^2", "wy^2", "wz^2"};
  for (int a = 0; a < 3; ++a) {
    SignalSeries s{sq[a], {}};
    for (int i : tests) s.values.push_back(std::pow(ctx[static_cast<std::size_t>(i)].w_S(a), 2));
    out.push_back(std::move(s));
  }
  if (lin.dw_dt.cols() == eng.data().size()) {
    for (int a = 0; a < 6; ++a) {
      SignalSeries s{std::string("d") + kWrenchAxisNames[a] + "/dt (model)", {}};
      for (int i : tests) s.values.push_back(lin.dw_dt(a, i));
      out.push_back(std::move(s));
    }
  }
  return out;
}

double pearson(const std::vector<double>& x, const Eigen::RowVectorXd& y) {
  const std::size_t n = x.size();
  double mx = 0.0, my = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    mx += x[i];
    my += y(static_cast<Eigen::Index>(i));
  }
  mx /= static_cast<double>(n);
  my /= static_cast<double>(n);
  double sxy = 0.0, sxx = 0.0, syy = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double dx = x[i] - mx;
    const double dy = y(static_cast<Eigen::Index>(i)) - my;
    sxy += dx * dy;
    sxx += dx * dx;
    syy += dy * dy;
  }
  if (sxx <= 0.0 || syy <= 0.0) return 0.0;
  return sxy / std::sqrt(sxx * syy);
}

/// Whether the robot moves somewhere in the log (whatever its columns): three or more consecutive
/// samples whose sensor pose moves (rotation angle plus displacement per second, from t, as
/// identify::poseGroups measures it) faster than ten times the median speed (the jitter of held
/// poses) and than 0.01 rad/s (+ m/s), ten times the speed poseGroups calls held still. Measured
/// per second, not per sample, so the same move counts at 10 Hz and at 1 kHz. A pose set's jump
/// from one pose to the next is one sample.
bool hasMoves(const std::vector<SampleContext>& ctx) {
  const std::size_t n = ctx.size();
  if (n < 4) return false;
  std::vector<double> speed(n, 0.0);
  for (std::size_t i = 1; i < n; ++i) {
    const double c = std::clamp(((ctx[i - 1].R_BS.transpose() * ctx[i].R_BS).trace() - 1.0) / 2.0, -1.0, 1.0);
    const double dt = ctx[i].t - ctx[i - 1].t;
    const double step = std::acos(c) + (ctx[i].p_BS_B - ctx[i - 1].p_BS_B).norm();
    speed[i] = dt > 0.0 ? step / dt : 0.0;  // untrusted clocks: a repeated or backward stamp is no move
  }
  std::vector<double> sorted(speed.begin() + 1, speed.end());
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
  const double threshold = std::max(1e-2, 10.0 * sorted[sorted.size() / 2]);
  int run = 0;
  for (std::size_t i = 1; i < n; ++i) {
    run = speed[i] > threshold ? run + 1 : 0;
    if (run >= 3) return true;
  }
  return false;
}

// A possible last model that `ftid identify --out` would still refuse (its mass or inertia is not
// determined): identify's reason, and the same model without rigid_body, fitted and judged by the
// same rules, as what it can write.
void noteUnwritable(const Engine& engine, const Fitted& last_fit, const FitView& view, AnalysisResult& result) {
  result.unwritable = writeRefusal(view);
  if (result.unwritable.empty() || !last_fit.model.contains("rigid_body")) return;
  std::vector<std::string> rest = detail::effectNames(last_fit.model);
  rest.erase(std::remove(rest.begin(), rest.end(), "rigid_body"), rest.end());
  if (rest.empty()) return;
  try {
    const Model alt = detail::canonicalModel(rest);
    auto [lin, sol] = engine.fitFully(alt, last_fit.lin);
    const FitView v = detail::fitView(alt, lin, sol, nullptr, engine.data().ctx);
    if (physicsRefusals(v).empty() && writeRefusal(v).empty()) result.writable_alternative = alt.name();
  } catch (const std::exception&) {  // no fit of the alternative: none is offered
    result.writable_alternative.clear();
  }
}

/// The spectrum of the held-out residual `result` holds (its last model's) and the search for
/// dynamics of the reading on `fit`, which the spectrum's motion band and peaks steer (not searched
/// once result holds change points: `fit` is then fitted across them).
std::pair<ResidualSpectrum, DynamicsCheck> readingDynamics(const detail::RankContext& rc, const Fitted& fit,
                                                           const AnalysisResult& result) {
  const auto& tests = rc.eng.testSamples();
  std::vector<char> excluded(tests.size(), 0);
  for (std::size_t k = 0; k < tests.size(); ++k) excluded[k] = rc.eng.excluded(tests[k]) ? 1 : 0;
  ResidualSpectrum spectrum = detail::spectrumOfAnalysis(result, excluded, rc.scale_sd);
  if (!result.change_points.empty()) {
    // A model fitted across a change in time: a filter would only smooth the step.
    DynamicsCheck none;
    none.note = "the log holds several set-ups, the change in time above: analyze each segment";
    return {std::move(spectrum), std::move(none)};
  }
  bool peak = false;
  for (const auto& ax : spectrum.axes) peak = peak || ax.peak.significant;
  DynamicsCheck dynamics = detail::checkDynamics(rc, fit, spectrum.motion_band_hz, peak);
  return {std::move(spectrum), std::move(dynamics)};
}

// Bounds on the arguments: 20 samples per held-out block, or 20 to fit and 8 to validate on.
void checkSampleCounts(const std::vector<SampleContext>& fit, const std::vector<SampleContext>* validate,
                       const AnalyzeOptions& options, const std::string& log_name, const std::string& validate_name) {
  const int n_fit = static_cast<int>(fit.size());
  if (validate == nullptr && options.folds < 2) throw ConfigError("--folds must be at least 2");
  const int min_samples = validate != nullptr ? 20 : 20 * options.folds;
  if (n_fit < min_samples) {
    throw DataError(log_name + ": " + std::to_string(n_fit) + " samples are too few for the analysis (need " +
                    std::to_string(min_samples) + ")");
  }
  if (validate != nullptr && validate->size() < 8) throw DataError(validate_name + ": too few samples to validate on");
}

// The data the engines fit: the fitting log followed by the validation log as the one test block,
// or the fitting log cut into held-out blocks holding equal shares of its moving samples
// (identify::foldBoundaries), whose start times the report marks. Weights are set later.
Dataset makeDataset(const std::vector<SampleContext>& fit, const std::vector<SampleContext>* validate,
                    const AnalyzeOptions& options, const std::string& log_name, const std::string& validate_name,
                    AnalysisResult& result) {
  const int n_fit = static_cast<int>(fit.size());
  Dataset d;
  d.ctx = fit;
  d.n_fit = n_fit;
  d.max_delay_s = options.max_delay_s;
  d.segment_start = {0};
  if (validate != nullptr) {
    d.external = true;
    d.ctx.insert(d.ctx.end(), validate->begin(), validate->end());
    d.blocks = {{0, n_fit, true}, {n_fit, static_cast<int>(d.ctx.size()), false}};
    d.segment_start.push_back(n_fit);
    if (validate->front().has_temp != fit.front().has_temp) {
      throw DataError(validate_name + ": the validation log must have the same columns (temp) as " + log_name);
    }
  } else {
    const std::vector<int> bounds = identify::foldBoundaries(fit, options.folds);
    for (int f = 0; f < options.folds; ++f) {
      d.blocks.push_back({bounds[static_cast<std::size_t>(f)], bounds[static_cast<std::size_t>(f) + 1], true});
      if (f > 0) result.fold_start_t.push_back(fit[static_cast<std::size_t>(bounds[static_cast<std::size_t>(f)])].t);
    }
  }
  (void)identify::poseGroups(fit, &d.static_data);
  // Held poses with moves between them: the moves show what a static pose set cannot (a delay).
  d.static_data = d.static_data && !hasMoves(fit);
  return d;
}

// Guards noise-free data: a floor far below the signal would make the weights meaningless.
constexpr double kTinyStd = 1e-9;

// A noise floor adopted: the report prints it and the fits use its colour and the weights
// 1 / innovation std of each axis.
void adoptNoiseFloor(const identify::NoiseFloor& nf, AnalysisResult& result, Dataset& d) {
  result.noise_method = identify::toString(nf.method);
  result.noise_detail = nf.detail;
  result.noise_ar1 = nf.ar1;
  result.noise_ar1_std = nf.ar1_std;
  result.noise_floor = nf.std;
  d.ar1 = nf.ar1;
  const Vec6 innovation = nf.innovationStd();
  for (int a = 0; a < 6; ++a) d.weights(a) = 1.0 / std::max(innovation(a), kTinyStd);
}

// The starting model can be fitted on d: its signals are logged, and no delay is asked of a
// static pose set (as for the candidates, and as identify::fitModel refuses).
void checkModelFits(const Model& model, const Dataset& d) {
  const std::string miss = detail::missingSignal(model, d.ctx);
  if (!miss.empty()) throw DataError("model '" + model.name() + "' cannot be fitted: " + miss);
  if (d.static_data && model.estimatesDelay()) {
    throw DataError("model '" + model.name() +
                    "' cannot be fitted: static pose set: a delay shows only while the wrench changes (the time "
                    "between poses is not motion); leave sensor_delay out");
  }
}

// The starting model's fit on an engine's data; refused when the data determine only some of its
// parameters.
std::pair<Linearization, Solution> fitStart(const Engine& e, const Model& model) {
  auto fitted = e.fitFully(model, e.initial(model));
  if (fitted.second.rank < fitted.second.p) {
    throw IdentificationError("model '" + model.name() + "': the data determine only " +
                              std::to_string(fitted.second.rank) + " of its " + std::to_string(fitted.second.p) +
                              " parameters (too little excitation for this model; see docs/analyze.md)");
  }
  return fitted;
}

// One reading per pose (no noise floor observable): the scale is the cross-validated residual of
// the starting model, fitted with provisional weights (the spread of each axis' readings).
void scaleFromHeldoutResidual(const std::vector<SampleContext>& fit, const Model& model, Dataset& d,
                              AnalysisResult& result) {
  const int n_fit = static_cast<int>(fit.size());
  for (int a = 0; a < 6; ++a) {
    double m = 0.0, ss = 0.0;
    for (int i = 0; i < n_fit; ++i) m += fit[static_cast<std::size_t>(i)].wrench_S(a) / n_fit;
    for (int i = 0; i < n_fit; ++i) ss += std::pow(fit[static_cast<std::size_t>(i)].wrench_S(a) - m, 2);
    d.weights(a) = 1.0 / std::max(std::sqrt(ss / n_fit), kTinyStd);
  }
  const Engine provisional(d);
  const auto fitted = fitStart(provisional, model);
  const Vec6 cv = (fitted.second.sse_heldout_axis / std::max(1, fitted.second.n_heldout)).cwiseSqrt();
  result.noise_floor = cv;
  for (int a = 0; a < 6; ++a) d.weights(a) = 1.0 / std::max(cv(a), kTinyStd);
  result.warnings.push_back("the noise floor is not observable (one reading per pose): the scale is the "
                            "cross-validated residual of " + model.name() +
                            ", so residual/noise ratios near 1 say nothing about the model; give the "
                            "sensor's noise with --noise fx=..,..,tz=..");
}

// The noise floor re-estimated on the first fit's residual of the fitting log (its colour, and its
// level where the readings hid it). Adopted when white or coloured; true when the fits' colour or
// weights changed (a reading clipped flat on most samples reads as a zero floor at first, and its
// weight of 1e9 made one axis the whole criterion).
bool refineNoise(const Mat6X& res_fit, const std::vector<SampleContext>& fit, identify::NoiseFloor& nf, Dataset& d,
                 AnalysisResult& result) {
  const Vec6 ar1_before = nf.ar1;
  const Vec6 weights_before = d.weights;
  const identify::KeptSeries kept_fit = identify::keptSeries(res_fit, fit, d.excluded);
  identify::refineNoiseFloor(nf, kept_fit.residual, kept_fit.ctx, kept_fit.segment_starts);
  if (!nf.observable() ||
      (nf.method != identify::NoiseMethod::kWhite && nf.method != identify::NoiseMethod::kColoured)) {
    return false;
  }
  adoptNoiseFloor(nf, result, d);
  return ar1_before != nf.ar1 || d.weights != weights_before;
}

// Glitches: isolated samples of the kept series far outside its robust spread
// (identify::detectOutliers), marked excluded in d and listed with their times and axes; true when
// any was found.
bool excludeGlitches(const identify::KeptSeries& kept, const std::vector<SampleContext>& fit,
                     const AnalyzeOptions& options, Dataset& d, AnalysisResult& result) {
  const auto flagged =  // identify::findGlitches' rule: a log that moves is a time series
      identify::detectOutliers(kept.residual, !identify::holdsStill(fit), options.glitch_threshold, kept.segment_starts);
  if (flagged.samples.empty()) return false;
  if (d.excluded.empty()) d.excluded.assign(static_cast<std::size_t>(d.size()), 0);
  for (std::size_t k = 0; k < flagged.samples.size(); ++k) {
    const int i = kept.index[static_cast<std::size_t>(flagged.samples[k])];
    d.excluded[static_cast<std::size_t>(i)] = 1;
    result.outliers.times.push_back(d.ctx[static_cast<std::size_t>(i)].t);
    result.outliers.axes.push_back(flagged.axes[k]);
  }
  result.outliers.count = static_cast<int>(result.outliers.times.size());
  say(options, std::to_string(result.outliers.count) + " glitch" + (result.outliers.count == 1 ? "" : "es") +
                   " (isolated samples beyond " + fmt(options.glitch_threshold, 3) +
                   " robust standard deviations) left out");
  return true;
}

// The residual of the first fit settles the noise colour (dense data, no data-sheet floor) and
// shows the glitches; both change the weights. d becomes the engine's data with those changes;
// true when the model must be re-fitted on it. Saturated samples are neither noise nor glitches:
// both are judged on the kept series.
bool refineAfterFirstFit(const Engine& eng, const Model& model, const Linearization& lin, const Solution& sol,
                         const std::vector<SampleContext>& fit, const AnalyzeOptions& options, identify::NoiseFloor& nf,
                         Dataset& d, AnalysisResult& result) {
  const int n_all = eng.data().size();
  const Mat6X pred = eng.predict(model, lin, sol.theta, false);
  Mat6X res(6, n_all);
  for (int i = 0; i < n_all; ++i) res.col(i) = eng.data().ctx[static_cast<std::size_t>(i)].wrench_S - pred.col(i);
  const identify::KeptSeries kept =
      identify::keptSeries(res, eng.data().ctx, eng.data().excluded, eng.data().segment_start);
  d = eng.data();
  bool changed = false;
  if (!options.noise_std) changed = refineNoise(res.leftCols(d.n_fit), fit, nf, d, result);
  if (options.glitch_threshold > 0.0) changed = excludeGlitches(kept, fit, options, d, result) || changed;
  return changed;
}

// The evaluated (held-out) samples' times and measured and predicted wrenches, into result;
// returns the held-out residual with the glitches zeroed, on which the statistics are taken (the
// plots keep them).
Mat6X heldoutSeries(const Engine& engine, const Solution& sol, AnalysisResult& result) {
  const auto& tests = engine.testSamples();
  result.measured.resize(6, static_cast<Eigen::Index>(tests.size()));
  for (std::size_t k = 0; k < tests.size(); ++k) {
    const auto& c = engine.data().ctx[static_cast<std::size_t>(tests[k])];
    result.t.push_back(c.t);
    result.measured.col(static_cast<Eigen::Index>(k)) = c.wrench_S;
  }
  result.predicted = result.measured - sol.heldout_residual;
  Mat6X stat_res = sol.heldout_residual;
  for (std::size_t k = 0; k < tests.size(); ++k) {
    if (engine.excluded(tests[k])) stat_res.col(static_cast<Eigen::Index>(k)).setZero();
  }
  return stat_res;
}

// Where it fails: the held-out residual in windows of equal sample counts, each as the rms of its
// residual over the noise floor (all axes); the worst options.top_windows first.
void failWindows(const Mat6X& stat_res, const AnalyzeOptions& options, AnalysisResult& result) {
  Vec6 w;
  for (int a = 0; a < 6; ++a) w(a) = 1.0 / std::max(result.noise_floor(a), 1e-9);
  const int n_eval = result.n_eval;
  const int nw = std::max(1, std::min(options.window_count, n_eval / 4));
  std::vector<FailWindow> windows;
  for (int k = 0; k < nw; ++k) {
    const int a = static_cast<int>(static_cast<long long>(n_eval) * k / nw);
    const int b = static_cast<int>(static_cast<long long>(n_eval) * (k + 1) / nw);
    Vec6 ss = Vec6::Zero();
    for (int i = a; i < b; ++i) ss += stat_res.col(i).cwiseProduct(w).cwiseAbs2();
    ss /= std::max(1, b - a);
    FailWindow fw;
    fw.t_start = result.t[static_cast<std::size_t>(a)];
    fw.t_end = result.t[static_cast<std::size_t>(b - 1)];
    fw.ratio = std::sqrt(ss.mean());
    ss.maxCoeff(&fw.worst_axis);
    result.window_ratio.push_back(fw.ratio);
    windows.push_back(fw);
  }
  result.window_length_s = n_eval > 1 ? (result.t.back() - result.t.front()) / nw : 0.0;
  std::sort(windows.begin(), windows.end(), [](const FailWindow& x, const FailWindow& y) { return x.ratio > y.ratio; });
  windows.resize(std::min<std::size_t>(windows.size(), static_cast<std::size_t>(std::max(0, options.top_windows))));
  result.windows = windows;
}

// ... and with what: the held-out residual's Pearson correlations with measured signals, the
// largest options.top_correlations first, each marked beyond 5 / sqrt(n); the top one's series.
void correlateResidual(const Engine& engine, const Linearization& lin, const Mat6X& stat_res,
                       const AnalyzeOptions& options, AnalysisResult& result) {
  const auto signals = diagnosticSignals(engine, lin);
  result.extra_signals = detail::extraSignals(engine.data().ctx).names;  // extra columns (extra_signals.hpp)
  std::vector<SignalCorrelation> corr;
  const double thresh = 5.0 / std::sqrt(std::max(1.0, static_cast<double>(result.n_eval)));
  for (const auto& s : signals) {
    for (int a = 0; a < 6; ++a) {
      const double r = pearson(s.values, stat_res.row(a));
      corr.push_back({s.name, a, r, std::abs(r) > thresh});
    }
  }
  std::sort(corr.begin(), corr.end(), [](const auto& x, const auto& y) { return std::abs(x.r) > std::abs(y.r); });
  corr.resize(std::min<std::size_t>(corr.size(), static_cast<std::size_t>(std::max(1, options.top_correlations))));
  result.correlations = corr;
  if (!corr.empty()) {
    for (const auto& s : signals) {
      if (s.name == corr.front().signal) result.top_signal = s.values;
    }
  }
}

// Which effect is missing: the menu ranked against the start, then a change in time
// (change_point_scan.hpp: a step no smooth effect describes; --explain then stops), else with
// --explain the path of added and removed effects. Returns the model the analysis ends at.
Fitted searchEffects(const detail::RankContext& rc, const Fitted& base, AnalysisResult& result) {
  const AnalyzeOptions& options = rc.options;
  result.candidates = detail::rankCandidates(rc, base);
  result.family_alpha = options.family_alpha;
  result.heldout_margin = options.min_relative_reduction;
  // With --explain, the path's end competes with the steps (its own record is dropped: the path
  // runs again below when no change point stands).
  std::function<detail::SmoothPath()> smooth_path;
  if (options.explain) {
    smooth_path = [&] {
      AnalyzeOptions quiet = options;
      quiet.progress = nullptr;
      const detail::RankContext quiet_rc{rc.eng, rc.menu, quiet, rc.log_cmd, rc.scale_sd, rc.family_size};
      AnalysisResult scratch = result;
      const Fitted end = detail::explainPath(quiet_rc, base, scratch);
      return detail::SmoothPath{end.model.name(), 1.0 - end.sol.sse_heldout / base.sol.sse_heldout};
    };
  }
  detail::reportChangePoints(rc, base, result, [&] { return readingDynamics(rc, base, result).second; }, smooth_path);
  return options.explain && result.change_points.empty() ? detail::explainPath(rc, base, result) : base;
}

// Impossible answers are never exported: what is wrong with the last model, in words; else what
// `ftid identify --out` would still refuse of it.
void noteRefusals(const Engine& engine, const Fitted& last_fit, AnalysisResult& result) {
  const FitView last_view = detail::fitView(last_fit.model, last_fit.lin, last_fit.sol, nullptr, engine.data().ctx);
  for (const auto& r : physicsRefusals(last_view)) {
    result.unphysical.push_back(r.reason);
    result.warnings.push_back(last_fit.model.name() + " is not physically possible: " + r.reason +
                              "; do not write or export its parameters");
  }
  if (result.unphysical.empty()) noteUnwritable(engine, last_fit, last_view, result);
}

// The residual's spectrum and autocorrelation (issue 22, sensor and mount dynamics), a delay
// judged against the IMU's (payload-free: estimated first), and the IMU against the last model
// (imu_check.hpp).
void judgeDynamicsAndImu(const detail::RankContext& rc, const std::vector<SampleContext>& fit, const Fitted& last_fit,
                         AnalysisResult& result) {
  detail::estimateImu(fit, &result);
  std::tie(result.spectrum, result.dynamics) = readingDynamics(rc, last_fit, result);
  detail::judgeDelayAgainstLag(rc, last_fit, result.imu, result.spectrum.motion_band_hz, &result.dynamics);
  // Across a change in time the residual's peaks are the step's (the change's warning says what to do).
  // Without --explain the spectrum and the IMU are judged on the starting model: the effect the
  // ranking recommends comes first in both warnings.
  const bool recommends = !result.final_report && !result.candidates.empty() && result.candidates.front().significant;
  const std::string missing = recommends ? result.candidates.front().effect : "";
  const std::string dynamics =
      result.change_points.empty() ? detail::spectrumWarning(result.spectrum, result.dynamics, missing) : std::string();
  if (!dynamics.empty()) result.warnings.push_back(dynamics);
  const std::string filtered = detail::dynamicsWarning(result.dynamics, result.noise_floor);
  if (!filtered.empty()) result.warnings.push_back(filtered);
  detail::checkImu(result.final_report ? *result.final_report : result.report, missing, &result);
}

}  // namespace

/// With --explain: the candidates refused against the starting model that the path did not take,
/// each with the motion that would decide it ("" when none). Where the path ends above the floor,
/// one of them may be what is missing (a crosstalk this motion cannot determine, imitated by
/// harmonics), which "no candidate explains" alone would hide.
std::string refusedAtTheStart(const AnalysisResult& r) {
  if (!r.final_report) return "";
  std::optional<Model> final_model;
  try {
    final_model.emplace(Model::fromName(r.final_report->model));
  } catch (const ConfigError&) {
    return "";
  }
  std::string out;
  for (const auto& c : r.candidates) {
    if (!c.confounded || final_model->contains(c.effect)) continue;
    out += (out.empty() ? "" : "; ") + c.effect + " (" + c.separating_motion + ")";
  }
  return out.empty() ? "" : "; refused against " + r.report.model + ", where a richer motion could decide: " + out;
}

std::vector<std::string> defaultGenericMenu() {
  return {"harmonic(q4,1)", "harmonic(q5,1)", "harmonic(q6,1)", "poly(t,2)", "poly(temp,2)"};
}

namespace {

// What is left: the last model's held-out residual against the noise floor (when observable),
// axes above identify::kAboveFloorMark named.
void aboveFloorWarning(const AnalyzeOptions& options, AnalysisResult& result) {
  const ModelReport& last = result.final_report ? *result.final_report : result.report;
  std::string above;
  for (int a = 0; a < 6; ++a) {
    const double ratio = last.residual_rms(a) / std::max(result.noise_floor(a), 1e-12);
    if (!(ratio > identify::kAboveFloorMark)) continue;  // (a NaN ratio is not above)
    above += std::string(above.empty() ? "" : ", ") + kWrenchAxisNames[a] + " " + fmt(ratio, 3) + "x";
  }
  if (above.empty()) return;
  result.warnings.push_back("the held-out residual of " + last.model + " is above the noise floor (" + above +
                            "): the model misses something" +
                            (!result.change_points.empty() ? ": the change in time (analyze each segment)"
                             : options.explain              ? " that no candidate explains" + refusedAtTheStart(result)
                                                            : "; try --explain"));
}

// The closing warnings: the residual above the floor; the effects not recommended (confounded)
// against the model the analysis ends at (after --explain, the final ranking's: an effect refused
// against the start, e.g. rigid_body before sensor_delay, may be in the final model); the glitches.
void closingWarnings(bool floor_observable, const AnalyzeOptions& options, AnalysisResult& result) {
  if (floor_observable) aboveFloorWarning(options, result);
  const bool explained = result.final_report.has_value();
  for (const auto& c : explained ? result.final_candidates : result.candidates) {
    if (c.confounded) {
      result.warnings.push_back(c.effect + " is not recommended" +
                                (explained ? " against " + result.final_report->model : std::string()) + ": " +
                                c.confound + "; to separate them: " + c.separating_motion);
    }
  }
  if (result.outliers.count > 0) {
    result.warnings.push_back(std::to_string(result.outliers.count) + " glitch" +
                              (result.outliers.count == 1 ? " was" : "es were") +
                              " left out of every fit (isolated spikes; see outliers)");
  }
}

}  // namespace

AnalysisResult analyze(const std::vector<SampleContext>& fit, const std::vector<SampleContext>* validate,
                       const AnalyzeOptions& options, const std::string& log_name, const std::string& validate_name) {
  const auto t_start = std::chrono::steady_clock::now();
  AnalysisResult result;
  result.log = log_name;
  result.validate_log = validate != nullptr ? validate_name : "";
  checkSampleCounts(fit, validate, options, log_name, validate_name);
  const int n_fit = static_cast<int>(fit.size());
  Dataset d = makeDataset(fit, validate, options, log_name, validate_name, result);
  // The noise floor: data sheet, or detected from the fitting log's readings.
  identify::NoiseFloor nf =
      options.noise_std ? identify::dataSheetNoiseFloor(*options.noise_std) : identify::estimateNoiseFloor(fit);
  adoptNoiseFloor(nf, result, d);
  result.n_samples = n_fit;
  result.folds = validate != nullptr ? 1 : options.folds;
  const Model model = Model::fromName(options.model);
  checkModelFits(model, d);
  const std::string log_cmd =
      shellQuote(log_name) + (validate != nullptr ? " --validate " + shellQuote(validate_name) : "");
  say(options, "noise floor: " + nf.detail);
  say(options, "fitting " + model.name() + " (" + std::to_string(model.numParams()) + " parameters) on " +
                   std::to_string(n_fit) + " samples, " +
                   (validate != nullptr ? "validating on " + validate_name
                                        : std::to_string(options.folds) + "-fold held-out blocks"));
  if (!nf.observable()) scaleFromHeldoutResidual(fit, model, d, result);
  detail::excludeSaturation(d, options, result);  // saturation (issue 22)
  auto eng = std::make_unique<Engine>(d);
  result.n_eval = static_cast<int>(eng->testSamples().size());
  auto [lin, sol] = fitStart(*eng, model);
  if (refineAfterFirstFit(*eng, model, lin, sol, fit, options, nf, d, result)) {
    say(options, "re-fitting " + model.name() + " (" + nf.detail + ")");
    eng = std::make_unique<Engine>(d);
    std::tie(lin, sol) = fitStart(*eng, model);
  }
  const Engine& engine = *eng;
  const Fitted base{model, lin, sol};
  result.report = detail::makeReport(engine, model, lin, sol);
  const Mat6X stat_res = heldoutSeries(engine, sol, result);
  failWindows(stat_res, options, result);
  correlateResidual(engine, lin, stat_res, options, result);
  const auto menu =  // the named effects, the generic menu and the extra columns' candidates
      detail::withExtraSignals(detail::candidateMenu(options), options, engine.data().ctx, &result.warnings);
  result.family_size = detail::familySize(engine, menu);
  const detail::RankContext rc{engine, menu, options, log_cmd,
                               detail::colourScaleSd(result.noise_ar1, result.noise_ar1_std), result.family_size};
  const Fitted last_fit = searchEffects(rc, base, result);
  noteRefusals(engine, last_fit, result);
  judgeDynamicsAndImu(rc, fit, last_fit, result);
  closingWarnings(nf.observable(), options, result);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return result;
}

}  // namespace ftid::lab
