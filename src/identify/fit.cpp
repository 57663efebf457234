// General weighted least-squares fit of a composed model with variable projection on the tilt
// (include/ftid/identify/fit.hpp, docs/identification.md). fitModel runs its steps in order
// (fit_steps.hpp): the checks and the start here, the nonlinear search (fit_search.cpp), the
// statistics at the optimum (fit_statistics.cpp); the problem itself in fit_problem.hpp, the
// compressed tilt search's data in gravity_compression.hpp.
#include "ftid/identify/fit.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include "fit_problem.hpp"
#include "fit_steps.hpp"
#include "linear_algebra.hpp"
#include "ftid/common/error.hpp"
#include "ftid/identify/paper_method.hpp"
#include "ftid/model/frames.hpp"

namespace ftid::identify {

namespace {

using effects::NonlinearParams;
using internal::FitState;
using internal::Problem;
using Mat6X = Eigen::Matrix<double, 6, Eigen::Dynamic>;

/// The checks of the options and the data before any fitting (the compressed tilt search's pass
/// checks the values for finiteness itself, prepareData).
void checkInputs(FitState& f) {
  Problem& pb = f.pb;
  const FitOptions& options = f.options;
  f.estimate_tilt = f.L.tilt >= 0;
  pb.override_gravity = f.estimate_tilt || (options.tilt_u_rad && options.tilt_v_rad);
  for (int idx : f.indices) {
    if (idx < 0 || static_cast<std::size_t>(idx) >= f.contexts.size()) {
      throw std::out_of_range("fitModel: sample index " + std::to_string(idx) + " out of range");
    }
  }
  f.n_unknowns = pb.p + f.L.size;
  if (pb.p == 0) throw IdentificationError("model '" + f.model.name() + "' has no parameters to fit");
  if (6 * pb.n < f.n_unknowns + 1) {
    throw IdentificationError("too few samples: " + std::to_string(pb.n) + " samples give " +
                              std::to_string(6 * pb.n) + " equations for " +
                              std::to_string(f.n_unknowns) + " unknowns of model '" + f.model.name() + "'");
  }
  // Tilt-only models try the compressed tilt search (GravityCompression), whose pass over the data
  // checks them for non-finite values as well.
  f.try_compressed = options.compressed_tilt_search && f.L.tilt >= 0 && f.L.size == 2 && !pb.reads_wmodel;
  if (!f.try_compressed) internal::checkFinite(pb);
  if (pb.delay) internal::checkTimeOrder(pb);
  if (pb.delay) internal::checkNotStatic(pb, f.model);
  if (pb.delay && !(options.max_delay_s > 0.0 && std::isfinite(options.max_delay_s))) {
    throw ConfigError("fit: the delay search range must be positive (got " + std::to_string(options.max_delay_s) + " s)");
  }
}

/// The tilt's start: the paper's static force stage (not determinable: start level; the rank
/// check decides). The compressed search solves it on its own data (the same problem, no second
/// pass).
void startTilt(FitState& f) {
  if (!f.estimate_tilt || f.tilt_given) return;
  f.st.fixed.tilt_u_rad = 0.0;
  f.st.fixed.tilt_v_rad = 0.0;
  if (!f.compressed ||
      !f.gc.initialTilt(PaperOptions().rank_tolerance, &f.st.fixed.tilt_u_rad, &f.st.fixed.tilt_v_rad)) {
    (void)initialTilt(f.contexts, f.indices, &f.st.fixed.tilt_u_rad, &f.st.fixed.tilt_v_rad);
  }
}

/// The data the search runs on and its start: tilt-only models build the compressed tilt search
/// (GravityCompression), unless the regressor turns out not to be affine in gravity (checked at
/// the given tilt, else at a generic off-axis gravity); the general path copies the measurement
/// (the compressed search holds it in its per-axis rows and needs neither copy).
void prepareData(FitState& f) {
  Problem& pb = f.pb;
  const FitOptions& options = f.options;
  // First pass of models that read the modelled wrench: wrench_model_S = 0, so their columns
  // vanish and the solve is the other effects' fit with E = 0 (a calibration error is small; the
  // measured wrench as a stand-in is an errors-in-variables start that can end in a false minimum).
  if (pb.reads_wmodel) pb.wmodel = std::vector<Wrench>(static_cast<std::size_t>(pb.n), Wrench::Zero());
  f.st.fixed.tilt_u_rad = options.tilt_u_rad.value_or(0.0);
  f.st.fixed.tilt_v_rad = options.tilt_v_rad.value_or(0.0);
  if (options.mount_rpy_rad) f.st.fixed.mount_rpy_rad = *options.mount_rpy_rad;
  f.tilt_given = options.tilt_u_rad && options.tilt_v_rad;
  f.compressed = f.try_compressed &&
                 f.gc.build(pb, model::gravityInBase(f.tilt_given ? f.st.fixed.tilt_u_rad : 0.3,
                                                     f.tilt_given ? f.st.fixed.tilt_v_rad : -0.2));
  if (f.try_compressed && !f.compressed) internal::checkFinite(pb);
  if (!f.compressed) {
    pb.y.resize(6 * pb.n);
    f.measured.resize(6, pb.n);
    for (int i = 0; i < pb.n; ++i) {
      pb.y.segment<6>(6 * i) = pb.at(i).wrench_S;
      f.measured.col(i) = pb.at(i).wrench_S;
    }
  }
  if (f.compressed) f.gc.factor(true);
  startTilt(f);
  f.st.phi = f.L.vector(f.st.fixed);
}

/// Rank of the linear part at the start (compressed: the same column norms and singular values
/// as the stacked regressor).
internal::RankReport rankAtStart(FitState& f) {
  Eigen::MatrixXd A;
  if (f.compressed) {
    Eigen::VectorXd z;
    const NonlinearParams nl0 = f.st.params(f.L);
    f.gc.compressed(model::gravityInBase(nl0.tilt_u_rad, nl0.tilt_v_rad), Vec6::Ones(), &A, &z);
  } else {
    f.pb.buildRegressor(f.st.params(f.L), Vec6::Ones(), &A);
  }
  return internal::analyzeRank(A, f.options.rank_tolerance);
}

/// The rank check at the start (the measured wrench stands in for the modelled one of the effects
/// that read it): throws IdentificationError naming the columns the data do not determine. A
/// compressed search too ill-conditioned for the Gram factor refactors by Householder QR.
void checkRankAtStart(FitState& f) {
  Problem& pb = f.pb;
  if (pb.reads_wmodel) {
    for (int i = 0; i < pb.n; ++i) pb.wmodel[static_cast<std::size_t>(i)] = f.measured.col(i);
  }
  internal::RankReport rr = rankAtStart(f);
  if (f.compressed && (rr.rank < pb.p || rr.condition_number > internal::kGramConditionLimit)) {
    // Too ill-conditioned for the Gram factor (or rank-deficient: decide on the exact one).
    f.gc.factor(false);
    startTilt(f);
    f.st.phi = f.L.vector(f.st.fixed);
    rr = rankAtStart(f);
  }
  if (rr.rank < pb.p) {
    std::vector<std::string> bad;
    for (int j : rr.unexcited_columns) bad.push_back(f.names[static_cast<std::size_t>(j)]);
    throw IdentificationError("the data do not determine " + internal::joinNames(bad) +
                              " of model '" + f.model.name() + "' (rank " + std::to_string(rr.rank) +
                              " of " + std::to_string(pb.p) +
                              "): excite them with more distinct orientations/motions");
  }
  if (pb.reads_wmodel) std::fill(pb.wmodel.begin(), pb.wmodel.end(), Wrench::Zero());
}

/// The estimates at the optimum into a FitResult (the statistics follow, statisticsAtOptimum).
FitResult estimates(const FitState& f) {
  const Problem& pb = f.pb;
  const NonlinearParams nl = f.st.params(f.L);
  FitResult res;
  res.model_name = f.model.name();
  res.params = f.model.params();
  res.theta = f.sol.theta;
  res.tilt_estimated = f.estimate_tilt;
  res.tilt_applied = pb.override_gravity;
  res.tilt_u_rad = pb.override_gravity ? nl.tilt_u_rad : 0.0;
  res.tilt_v_rad = pb.override_gravity ? nl.tilt_v_rad : 0.0;
  res.mounting_estimated = pb.mounting;
  res.mount_rpy_rad = pb.mounting ? nl.mount_rpy_rad : Vec3::Zero();
  res.delay_estimated = pb.delay;
  res.delay_s = pb.delay ? nl.delay_s : 0.0;
  res.n_excluded = pb.n - pb.n_active;
  res.tilt_iterations = f.st.iterations;
  res.axis_weights = f.weights;
  res.n_samples = pb.n_active;
  return res;
}

/// Derived parameters: com = mass_com / mass, weight = m g (delta method).
void addDerivedParameters(const Model& model, FitResult* out) {
  FitResult& res = *out;
  const auto& index = model.paramIndex();
  const int cm = index.column("mass");
  if (cm < 0) return;
  res.derived.push_back({"weight", kStandardGravity * res.theta(cm),
                         kStandardGravity * res.theta_std(cm), "N"});
  const char* mc_names[3] = {"mass_com_x", "mass_com_y", "mass_com_z"};
  const char* com_names[3] = {"com_x", "com_y", "com_z"};
  for (int k = 0; k < 3; ++k) {
    const int cj = index.column(mc_names[k]);
    if (cj < 0) continue;
    const double m = res.theta(cm);
    const double mc = res.theta(cj);
    Eigen::Vector2d grad(-mc / (m * m), 1.0 / m);
    Eigen::Matrix2d C;
    C << res.covariance(cm, cm), res.covariance(cm, cj), res.covariance(cj, cm), res.covariance(cj, cj);
    res.derived.push_back({com_names[k], mc / m, std::sqrt(std::max(grad.dot(C * grad), 0.0)), "m"});
  }
}

}  // namespace

Mat6X timeDerivative(const std::vector<double>& t, const Mat6X& w, const std::vector<int>& segment_start) {
  const int n = static_cast<int>(w.cols());
  Mat6X d = Mat6X::Zero(6, n);
  std::vector<int> starts = segment_start;
  if (starts.empty()) starts.push_back(0);
  starts.push_back(n);
  for (std::size_t s = 0; s + 1 < starts.size(); ++s) {
    const int a0 = starts[s];
    const int a1 = starts[s + 1];
    for (int i = a0; i < a1; ++i) {
      const int a = std::max(i - 1, a0);
      const int b = std::min(i + 1, a1 - 1);
      const double dt = t[static_cast<std::size_t>(b)] - t[static_cast<std::size_t>(a)];
      if (b > a && dt > 0.0) d.col(i) = (w.col(b) - w.col(a)) / dt;
    }
  }
  return d;
}

bool initialTilt(const std::vector<SampleContext>& contexts, const std::vector<int>& indices, double* tilt_u_rad,
                 double* tilt_v_rad) {
  bool all = indices.size() == contexts.size();  // all contexts in order: no copy
  for (std::size_t k = 0; all && k < indices.size(); ++k) all = indices[k] == static_cast<int>(k);
  std::vector<SampleContext> subset;
  if (!all) {
    subset.reserve(indices.size());
    for (int idx : indices) subset.push_back(contexts[static_cast<std::size_t>(idx)]);
  }
  try {
    PaperOptions po;
    po.method = PaperMethod::kStatic;
    const PaperResult pr = identifyPaper(all ? contexts : subset, po);
    *tilt_u_rad = pr.tilt_u_rad;
    *tilt_v_rad = pr.tilt_v_rad;
    return true;
  } catch (const Error&) {
    return false;
  }
}

double initialDelayEstimate(const std::vector<double>& t, const Mat6X& measured, const Mat6X& pred,
                            const Vec6& w, double max_delay_s) {
  const int n = static_cast<int>(t.size());
  if (n < 3 || measured.cols() != n || pred.cols() != n) return 0.0;
  const double t0 = t.front();
  const double t1 = t.back();
  auto cost = [&](double tau) {
    double sse = 0.0;
    int count = 0;
    int k = 0;
    for (int i = 0; i < n; ++i) {
      const double ts = t[static_cast<std::size_t>(i)] - tau;
      if (ts < t0 || ts > t1) continue;
      while (k + 1 < n - 1 && t[static_cast<std::size_t>(k + 1)] <= ts) ++k;
      while (k > 0 && t[static_cast<std::size_t>(k)] > ts) --k;
      const int k1 = std::min(k + 1, n - 1);
      const double dt = t[static_cast<std::size_t>(k1)] - t[static_cast<std::size_t>(k)];
      const double s = dt > 0.0 ? std::clamp((ts - t[static_cast<std::size_t>(k)]) / dt, 0.0, 1.0) : 0.0;
      const Vec6 m = (1.0 - s) * pred.col(k) + s * pred.col(k1);
      sse += w.cwiseProduct(measured.col(i) - m).squaredNorm();
      ++count;
    }
    // Shifts that keep too little of the data are not trusted.
    return count >= std::max(8, n / 4) ? sse / count : std::numeric_limits<double>::infinity();
  };
  // First-order estimate: residual ~ -tau dw/dt (central differences).
  double num = 0.0;
  double den = 0.0;
  const Mat6X dpred = timeDerivative(t, pred);
  for (int i = 0; i < n; ++i) {
    const Vec6 d = -w.cwiseProduct(dpred.col(i));
    const Vec6 r = w.cwiseProduct(measured.col(i) - pred.col(i));
    num += d.dot(r);
    den += d.squaredNorm();
  }
  double best = 0.0;
  double best_cost = cost(0.0);
  auto consider = [&](double tau) {
    if (!(std::abs(tau) <= max_delay_s)) return;
    const double c = cost(tau);
    if (c < best_cost) {
      best_cost = c;
      best = tau;
    }
  };
  if (den > 0.0) consider(num / den);
  const double dt_mean = (t1 - t0) / (n - 1);
  const double h = std::max(dt_mean, max_delay_s / 200.0);
  const int steps = static_cast<int>(std::ceil(max_delay_s / h));
  for (int s = -steps; s <= steps; ++s) consider(s * h);
  const double center = best;
  for (int s = -10; s <= 10; ++s) consider(center + s * h / 10.0);
  return best;
}

effects::NonlinearParams FitResult::nonlinear() const {
  effects::NonlinearParams p;
  p.tilt_u_rad = tilt_u_rad;
  p.tilt_v_rad = tilt_v_rad;
  p.mount_rpy_rad = mount_rpy_rad;
  p.delay_s = delay_s;
  return p;
}

double FitResult::value(const std::string& name) const {
  for (std::size_t j = 0; j < params.size(); ++j) {
    if (params[j].name == name) return theta(static_cast<Eigen::Index>(j));
  }
  for (const auto& d : derived) {
    if (d.name == name) return d.value;
  }
  if (name == "tilt_u") return tilt_u_rad;
  if (name == "tilt_v") return tilt_v_rad;
  for (int k = 0; k < 3; ++k) {
    if (mounting_estimated && name == effects::kMountParamNames[k]) return mount_rpy_rad(k);
  }
  if (delay_estimated && name == effects::kDelayParamName) return delay_s;
  throw std::out_of_range("fit result has no parameter '" + name + "'");
}

double FitResult::stddev(const std::string& name) const {
  for (std::size_t j = 0; j < params.size(); ++j) {
    if (params[j].name == name) return theta_std(static_cast<Eigen::Index>(j));
  }
  for (const auto& d : derived) {
    if (d.name == name) return d.std;
  }
  if (name == "tilt_u") return tilt_u_std;
  if (name == "tilt_v") return tilt_v_std;
  for (int k = 0; k < 3; ++k) {
    if (mounting_estimated && name == effects::kMountParamNames[k]) return mount_rpy_std(k);
  }
  if (delay_estimated && name == effects::kDelayParamName) return delay_std;
  throw std::out_of_range("fit result has no parameter '" + name + "'");
}

bool FitResult::has(const std::string& name) const {
  try {
    (void)value(name);
    return true;
  } catch (const std::out_of_range&) {
    return false;
  }
}

FitResult fitModel(const Model& model, const std::vector<SampleContext>& contexts,
                   const FitOptions& options) {
  std::vector<int> all(contexts.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  return fitModel(model, contexts, all, options);
}

// The steps in order (fit_steps.hpp); each passes on what it found in FitState.
FitResult fitModel(const Model& model, const std::vector<SampleContext>& contexts,
                   const std::vector<int>& indices, const FitOptions& options) {
  FitState f(model, contexts, indices, options);
  checkInputs(f);
  prepareData(f);
  f.names = model.paramIndex().names();
  checkRankAtStart(f);
  internal::searchNonlinear(f);
  FitResult res = estimates(f);
  internal::statisticsAtOptimum(f, &res);
  addDerivedParameters(model, &res);
  return res;
}

Eigen::Matrix<double, 6, Eigen::Dynamic> predictWrench(const Model& model, const Eigen::VectorXd& theta,
                                                       const effects::NonlinearParams& nonlinear,
                                                       bool apply_tilt,
                                                       const std::vector<SampleContext>& contexts,
                                                       const std::vector<int>& indices) {
  if (theta.size() != model.numParams()) {
    throw std::invalid_argument("predictWrench: theta has " + std::to_string(theta.size()) +
                                " entries, model '" + model.name() + "' has " +
                                std::to_string(model.numParams()) + " parameters");
  }
  internal::Problem pb(model, contexts, indices);
  pb.override_gravity = apply_tilt;
  if (pb.n == 0) return Mat6X(6, 0);
  return pb.predict(theta, nonlinear);
}

Eigen::Matrix<double, 6, Eigen::Dynamic> predictWrench(const Model& model, const Eigen::VectorXd& theta,
                                                       std::optional<double> tilt_u_rad,
                                                       std::optional<double> tilt_v_rad,
                                                       const std::vector<SampleContext>& contexts,
                                                       const std::vector<int>& indices) {
  effects::NonlinearParams nl;
  nl.tilt_u_rad = tilt_u_rad.value_or(0.0);
  nl.tilt_v_rad = tilt_v_rad.value_or(0.0);
  return predictWrench(model, theta, nl, tilt_u_rad.has_value() && tilt_v_rad.has_value(), contexts, indices);
}

Eigen::Matrix<double, 6, Eigen::Dynamic> predictWrench(const Model& model, const FitResult& fit,
                                                       const std::vector<SampleContext>& contexts,
                                                       const std::vector<int>& indices) {
  return predictWrench(model, fit.theta, fit.nonlinear(), fit.tilt_applied, contexts, indices);
}

Eigen::Matrix<double, 6, Eigen::Dynamic> predictWrench(const Model& model, const FitResult& fit,
                                                       const std::vector<SampleContext>& contexts) {
  std::vector<int> all(contexts.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  return predictWrench(model, fit, contexts, all);
}

}  // namespace ftid::identify
